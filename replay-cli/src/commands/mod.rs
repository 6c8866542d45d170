//! One module per subcommand, each with a `command` function that takes the subcommand's
//! arguments (see `cli`) and returns its exit code. Modules shared by several commands: `run`
//! (a run into a directory: `fork`, `sweep`, `fixtures` and `bench` make runs too),
//! `inspect` (the warning for a truncated log) and `ranking` (the logs under a sweep's results,
//! which `traffic` reads too).

pub mod bench;
pub mod bisect;
pub mod chaos;
pub mod config;
pub mod data_volume;
pub mod diff;
pub mod export;
pub mod fixtures;
pub mod fork;
pub mod inspect;
pub mod live;
pub mod presets;
pub mod ranking;
pub mod recheck;
pub mod replay;
pub mod report;
pub mod run;
pub mod snapshot;
pub mod sweep;
pub mod traffic;
pub mod view;

//! One module per subcommand, each with a `command` function that takes the subcommand's
//! arguments (see `cli`), calls the core or the study crate (`swarmfl-study`) and prints; it
//! returns the exit code. Commands do not import each other: what two of them share is outside
//! `commands/` (`summary`, `progress`, `live`).

pub mod bench;
pub mod bisect;
pub mod blame;
pub mod chaos;
pub mod config;
pub mod contributions;
pub mod data_volume;
pub mod diff;
pub mod export;
pub mod fixtures;
pub mod fork;
pub mod inspect;
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

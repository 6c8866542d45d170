//! Studies over swarmfl runs, between the core (`swarmfl-core`: the simulation, its log and its
//! folds) and its front ends (`replay-cli`'s `swarmfl` command and the Python package).
//!
//! It owns running a configuration to a log and a summary ([`run`]), forks ([`fork`]) and
//! exports ([`export`]), the experiments ([`experiments`], named once) and grids ([`grid`]),
//! summaries and result files, typed ([`summary`], [`results`]), sweeps ([`sweep`]) and rechecks ([`recheck`]), reports
//! ([`report`]), ranking ([`ranking`]), traffic ([`traffic`]) and data volume
//! ([`data_volume`]), and the pictures: figures (in [`report`]), the world ([`snapshot`]) and
//! the viewer ([`view`]). It prints nothing: a long job shows its progress and says its
//! warnings through [`progress::Watch`], which each front end implements.

pub mod blame;
pub mod data_volume;
pub mod experiments;
pub mod export;
pub mod fork;
pub mod grid;
pub mod png;
pub mod progress;
pub mod ranking;
pub mod recheck;
pub mod report;
pub mod results;
pub mod run;
pub mod run_dir;
pub mod snapshot;
pub mod summary;
pub mod sweep;
pub mod traffic;
pub mod view;

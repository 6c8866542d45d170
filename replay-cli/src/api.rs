//! What the Python package (`python/`) calls: the command's own functions, so that a run or an
//! export made from Python writes exactly the files the command writes.

use std::path::Path;

use swarmfl_core::config::Config;

pub use crate::commands::run::RunOutcome;

/// Runs `config` with `seed` into `out` (`out/run.swlog`, `out/summary.json`), as `swarmfl
/// run` does; `quiet` hides the progress bar.
pub fn run(config: Config, seed: u64, out: &Path, quiet: bool) -> anyhow::Result<RunOutcome> {
    crate::commands::run::run(config, seed, out, quiet)
}

/// Writes the CSV tables of the log at `log` into `out`, as `swarmfl export` does.
pub fn export(log: &Path, out: &Path) -> anyhow::Result<()> {
    crate::commands::export::export(log, out)
}

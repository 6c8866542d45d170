//! What the Python package (`python/`) calls: the command's own functions, so that a run or an
//! export made from Python writes exactly the files the command writes.

use std::path::Path;

use swarmfl_core::byzantine::plugin::Plugins;
use swarmfl_core::config::Config;

pub use crate::commands::report::{results_frame, Frame};
pub use crate::commands::run::RunOutcome;
pub use crate::commands::sweep::{Shard, SweepOptions, SweepOutcome, TaskDone};

/// Runs `config` with `seed` into `out` (`out/run.swlog`, `out/summary.json`), as `swarmfl
/// run` does; `quiet` hides the progress bar.
pub fn run(config: Config, seed: u64, out: &Path, quiet: bool) -> anyhow::Result<RunOutcome> {
    crate::commands::run::run(config, seed, out, quiet)
}

/// [`run`], interrupted at the next record once `stop` is set (an error saying so; the log
/// left in `out` is truncated).
pub fn run_until(
    config: Config,
    seed: u64,
    out: &Path,
    quiet: bool,
    stop: &std::sync::atomic::AtomicBool,
) -> anyhow::Result<RunOutcome> {
    crate::commands::run::run_until(config, seed, out, quiet, stop)
}

/// [`run`] offered `plugins` (plug-in attacks); `check` runs before every record is written and
/// its error stops the run, leaving the log in `out` truncated.
pub fn run_with_plugins(
    config: Config,
    seed: u64,
    out: &Path,
    quiet: bool,
    plugins: &Plugins,
    check: impl FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<RunOutcome> {
    crate::commands::run::run_with_plugins(
        config,
        seed,
        out,
        quiet,
        plugins,
        crate::commands::run::Flush::WhenFull,
        check,
    )
}

/// Forks the log at `parent` at block `height` with `overrides` into `out`, as `swarmfl fork`
/// does, offered `plugins` (the parent's must be among them, with the recorded sources);
/// `check` as in [`run_with_plugins`].
pub fn fork_with_plugins(
    parent: &Path,
    height: u64,
    overrides: &[String],
    out: &Path,
    quiet: bool,
    plugins: &Plugins,
    check: impl FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    crate::commands::fork::fork_with(
        parent,
        height,
        overrides,
        Some(out.to_path_buf()),
        quiet,
        plugins,
        check,
    )
}

/// Writes the CSV tables of the log at `log` into `out`, as `swarmfl export` does.
pub fn export(log: &Path, out: &Path) -> anyhow::Result<()> {
    crate::commands::export::export(log, out)
}

/// Runs a sweep (a built-in experiment or a grid), as `swarmfl sweep` does; `hook` gets every
/// finished task (and stops the sweep by returning false) instead of the progress bar.
pub fn sweep(
    opts: &SweepOptions,
    hook: Option<&(dyn Fn(&TaskDone) -> bool + Sync)>,
) -> anyhow::Result<SweepOutcome> {
    crate::commands::sweep::sweep(opts, hook)
}

/// Writes the report of a results directory (`swarmfl report DIR --out OUT`); returns the path
/// of its report.md.
pub fn report(dir: &Path, out: &Path) -> anyhow::Result<std::path::PathBuf> {
    crate::commands::report::report(dir, out)
}

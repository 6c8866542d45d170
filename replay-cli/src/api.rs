//! What the Python package (`python/`) calls: the command's own functions, so that a run or an
//! export made from Python writes exactly the files the command writes.

use std::path::Path;

use swarmfl_core::byzantine::plugin::Plugins;

pub use crate::commands::report::{results_frame, Frame};
// The command's own run functions (one definition each, documented there): `run` writes
// `out/run.swlog` and `out/summary.json` as `swarmfl run` does, `run_until` stops at the next
// record once its flag is set, `run_with_plugins` offers plug-ins and a check before every
// record (Python passes `Flush::WhenFull`).
pub use crate::commands::run::{run, run_until, run_with_plugins, Flush, RunOutcome};
pub use crate::commands::sweep::{Shard, SweepOptions, SweepOutcome, TaskDone};
pub use crate::commands::view::ViewOutcome;

/// Forks the log at `parent` at block `height` with `overrides` into `out`, as `swarmfl fork`
/// does, offered `plugins` (the parent's must be among them, with the recorded sources);
/// `check` as in [`run_with_plugins`]. A run already in `out` is replaced (said on stderr);
/// the parent's own folder is refused.
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
        (out, crate::run_dir::Chosen::Explicit),
        quiet,
        plugins,
        check,
    )
}

/// Writes the viewer of the log at `log` (one self-contained HTML file) into `out`, as
/// `swarmfl view` does.
pub fn view(log: &Path, out: &Path) -> anyhow::Result<ViewOutcome> {
    crate::commands::view::view(log, out)
}

/// Draws the world of the log at `log` at `time` seconds or right after `block` into `out`
/// (SVG or PNG), as `swarmfl snapshot` does; returns the picture's title.
pub fn snapshot(
    log: &Path,
    time: Option<f64>,
    block: Option<u64>,
    out: &Path,
) -> anyhow::Result<String> {
    crate::commands::snapshot::snapshot(log, time, block, out)
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

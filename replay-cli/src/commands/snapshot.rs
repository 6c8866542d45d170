//! `swarmfl snapshot`: the world at a block or a time ([`swarmfl_study::snapshot`]), drawn
//! into `--out`.

use std::process::ExitCode;

use swarmfl_study::snapshot::snapshot;

use crate::cli::SnapshotArgs;
use crate::progress::Bar;

/// Runs `swarmfl snapshot`: the world at a block or a time, drawn into `--out`.
pub fn command(args: SnapshotArgs) -> anyhow::Result<ExitCode> {
    let SnapshotArgs {
        log,
        time,
        block,
        out,
    } = args;
    let title = snapshot(&log, time, block, &out, &Bar::new(false))?;
    println!("wrote {} ({title}; from {})", out.display(), log.display());
    Ok(ExitCode::SUCCESS)
}

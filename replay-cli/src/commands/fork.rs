//! `swarmfl fork LOG --at H --set k=v [--out DIR]`: continue a run from block H under a changed
//! configuration ([`swarmfl_study::fork`]), then print its summary and the fork's line.

use std::process::ExitCode;

use swarmfl_study::fork::fork;
use swarmfl_study::run_dir;

use crate::cli::ForkArgs;
use crate::progress::Bar;
use crate::summary::print_summary;

/// Runs `swarmfl fork`.
pub fn command(args: ForkArgs) -> anyhow::Result<ExitCode> {
    let ForkArgs {
        log,
        at,
        overrides,
        out,
        force,
        quiet,
    } = args;
    let (out, chosen) = run_dir::choose(out, force, || {
        Ok(run_dir::default_fork_dir(&log, at, &overrides))
    })?;
    let outcome = fork(&log, at, &overrides, &out, chosen, &Bar::new(quiet))?;
    if !quiet {
        print_summary(&outcome.run);
        println!(
            "fork:       parent {} at block {} (fork point t = {}); {} records identical to the parent's; {:.1} s",
            log.display(),
            at,
            outcome.fork_point,
            outcome.identical,
            outcome.wall_s
        );
    }
    Ok(ExitCode::SUCCESS)
}

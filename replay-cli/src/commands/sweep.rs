//! `swarmfl sweep`: runs a built-in experiment or a grid ([`swarmfl_study::sweep`]), then
//! prints one line of counts and every failure.

use std::process::ExitCode;

use swarmfl_study::sweep::{sweep, Shard, SweepOptions};

use crate::cli::SweepArgs;
use crate::progress::Bar;

/// Runs `swarmfl sweep`: the shard's tasks, then one line of counts and every failure.
pub fn command(args: SweepArgs) -> anyhow::Result<ExitCode> {
    let SweepArgs {
        experiment,
        preset,
        grid,
        out,
        runs,
        jobs,
        shard,
        shards,
        overrides,
        keep_logs,
    } = args;
    let shard = Shard::resolve(shard.as_deref(), shards, |k| std::env::var(k).ok())?;
    let outcome = sweep(
        &SweepOptions {
            experiment,
            preset,
            grid,
            out,
            runs,
            jobs,
            shard,
            overrides,
            keep_logs,
        },
        &Bar::new(false),
        None,
    )?;
    println!(
        "sweep: {} tasks in shard, {} ran, {} already done, {} failed, {:.1} s",
        outcome.selected,
        outcome.ran,
        outcome.skipped,
        outcome.failed.len(),
        outcome.wall_s
    );
    if !outcome.failed.is_empty() {
        for (task, error) in &outcome.failed {
            eprintln!(
                "task {} ({} seed {}): {error}",
                task.index, task.point, task.seed
            );
        }
        anyhow::bail!(
            "{} tasks failed; re-run the same command to retry them",
            outcome.failed.len()
        );
    }
    Ok(ExitCode::SUCCESS)
}

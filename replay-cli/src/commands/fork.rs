//! `swarmfl fork LOG --at H --set k=v [--out DIR]`: continue a run from block H under a changed
//! configuration.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use swarmfl_core::byzantine::plugin::Plugins;
use swarmfl_core::fork::{self, PrefixCheck};
use swarmfl_core::sim::Sim;

use crate::cli::ForkArgs;
use crate::commands::run;

/// Runs `swarmfl fork`.
pub fn command(args: ForkArgs) -> anyhow::Result<ExitCode> {
    let ForkArgs {
        log,
        at,
        overrides,
        out,
        quiet,
    } = args;
    fork(&log, at, &overrides, out, quiet)?;
    Ok(ExitCode::SUCCESS)
}

/// Plans the fork, re-simulates the parent up to the fork point (checking every record against
/// the parent's log), continues under the new configuration and writes `DIR/run.swlog` and
/// `DIR/summary.json`.
pub fn fork(
    parent: &Path,
    height: u64,
    overrides: &[String],
    out: Option<PathBuf>,
    quiet: bool,
) -> anyhow::Result<()> {
    fork_with(
        parent,
        height,
        overrides,
        out,
        quiet,
        &Plugins::none(),
        || Ok(()),
    )
}

/// [`fork`] offered `plugins` (the Python package's attacks; the parent's must be among them
/// with the sources its header records); `check` runs before every record is written and its
/// error stops the fork (a plug-in that failed). Returns the fork's directory.
pub fn fork_with(
    parent: &Path,
    height: u64,
    overrides: &[String],
    out: Option<PathBuf>,
    quiet: bool,
    plugins: &Plugins,
    mut stop: impl FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let started = Instant::now();
    let plan = fork::plan_with(parent, height, overrides, plugins)?;
    let out = out.unwrap_or_else(|| {
        parent
            .parent()
            .unwrap_or(Path::new("."))
            .join(format!("fork-at-{height}"))
    });
    if !quiet {
        let values = plan.config.flat_values();
        eprintln!(
            "fork of {} at block {} (sealed at t = {}, fork point t = {}): {}",
            parent.display(),
            height,
            plan.sealed_at,
            plan.at,
            plan.changed
                .iter()
                .map(|k| format!("{k} = {}", values.get(k).map_or("?", String::as_str)))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let mut check = PrefixCheck::open(parent, &plan)?;
    let sim = Sim::forked_with(
        plan.root.clone(),
        plan.seed,
        &plan.reconfigurations,
        plugins,
    )?;
    let outcome = run::write_run(
        &plan.header,
        sim,
        &out,
        quiet,
        run::Flush::WhenFull,
        |record| {
            stop()?;
            check.check(record).map_err(anyhow::Error::from)
        },
    )?;
    anyhow::ensure!(
        check.done(),
        "the fork never reached its reconfiguration (a bug: the plan's fork point is inside the run)"
    );
    if !quiet {
        run::print_summary(&outcome);
        println!(
            "fork:       parent {} at block {} (fork point t = {}); {} records identical to the parent's; {:.1} s",
            parent.display(),
            height,
            plan.at,
            check.checked(),
            started.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

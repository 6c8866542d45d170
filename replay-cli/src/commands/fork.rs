//! `swarmfl fork LOG --at H --set k=v [--out DIR]`: continue a run from block H under a changed
//! configuration.

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use swarmfl_core::byzantine::plugin::Plugins;
use swarmfl_core::fork::{self, PrefixCheck};
use swarmfl_core::sim::Sim;

use crate::cli::ForkArgs;
use crate::commands::run;
use crate::run_dir::{self, Chosen};

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
    fork(&log, at, &overrides, &out, chosen, quiet)?;
    Ok(ExitCode::SUCCESS)
}

/// Plans the fork, re-simulates the parent up to the fork point (checking every record against
/// the parent's log), continues under the new configuration and writes `out/run.swlog` and
/// `out/summary.json`; a run already in `out` is replaced or refused as
/// [`run_dir::prepare`] says for a folder `chosen` so, and the parent's own folder is refused.
pub fn fork(
    parent: &Path,
    height: u64,
    overrides: &[String],
    out: &Path,
    chosen: Chosen,
    quiet: bool,
) -> anyhow::Result<()> {
    fork_with(
        parent,
        height,
        overrides,
        (out, chosen),
        quiet,
        &Plugins::none(),
        || Ok(()),
    )
}

/// [`fork`] into `out` (its folder and how it was chosen) offered `plugins` (the Python
/// package's attacks; the parent's must be among them with the sources its header records);
/// `check` runs before every record is written and its error stops the fork (a plug-in that
/// failed).
pub fn fork_with(
    parent: &Path,
    height: u64,
    overrides: &[String],
    (out, chosen): (&Path, Chosen),
    quiet: bool,
    plugins: &Plugins,
    mut stop: impl FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let started = Instant::now();
    // Before the plan, which may fold the whole parent: a fork into its parent's folder would
    // truncate the log it is about to read.
    let default = run_dir::default_fork_dir(parent, height, overrides);
    run_dir::refuse_parent_folder(parent, out, &default)?;
    let plan = fork::plan_with(parent, height, overrides, plugins)?;
    if let Some(replaced) = run_dir::prepare(out, &plan.header, chosen)? {
        eprintln!("{replaced}");
    }
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
        out,
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

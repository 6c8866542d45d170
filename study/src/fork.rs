//! A fork: continue a run from block H under a changed configuration (`swarmfl fork`).

use std::path::Path;
use std::time::Instant;

use swarmfl_core::byzantine::plugin::Plugins;
use swarmfl_core::fork::{self, PrefixCheck};
use swarmfl_core::sim::Sim;

use crate::progress::Watch;
use crate::run::{self, RunOutcome};
use crate::run_dir::{self, Chosen};

/// What a finished fork reports.
pub struct ForkOutcome {
    /// The fork's run, as [`run::write_run`] reports it.
    pub run: RunOutcome,
    /// The fork point's simulated time.
    pub fork_point: swarmfl_core::SimTime,
    /// Records re-simulated identical to the parent's.
    pub identical: u64,
    /// Wall seconds the fork took.
    pub wall_s: f64,
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
    watch: &dyn Watch,
) -> anyhow::Result<ForkOutcome> {
    fork_with(
        parent,
        height,
        overrides,
        (out, chosen),
        watch,
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
    watch: &dyn Watch,
    plugins: &Plugins,
    mut stop: impl FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<ForkOutcome> {
    let started = Instant::now();
    // Before the plan, which may fold the whole parent: a fork into its parent's folder would
    // truncate the log it is about to read.
    let default = run_dir::default_fork_dir(parent, height, overrides);
    run_dir::refuse_parent_folder(parent, out, &default)?;
    let plan = fork::plan_with(parent, height, overrides, plugins)?;
    if let Some(replaced) = run_dir::prepare(out, &plan.header, chosen)? {
        watch.warn(&replaced);
    }
    {
        let values = plan.config.flat_values();
        watch.say(&format!(
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
        ));
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
        watch,
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
    Ok(ForkOutcome {
        run: outcome,
        fork_point: plan.at,
        identical: check.checked(),
        wall_s: started.elapsed().as_secs_f64(),
    })
}

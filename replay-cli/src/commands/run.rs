//! `swarmfl run`: simulate a run into `DIR/run.swlog` and `DIR/summary.json`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use swarmfl_core::config::Config;
use swarmfl_core::event::Record;
use swarmfl_core::log::{Header, LogWriter};
use swarmfl_core::sim::{Part, Profiler, Sim};
use swarmfl_core::state::State;
use swarmfl_core::summary::RunSummary;

use crate::cli::RunArgs;
use crate::progress::Progress;

/// Wall time and CPU time per part of the driver, shared with the driver's profiler hook.
/// The wall time of a part is the driver thread's time in it (for learning: training, or
/// waiting for trainings on the pool). The driver thread's own CPU time goes to the part it is
/// in; the CPU time of every other thread of the process goes to learning, because the only
/// other threads that work are the trainings (rayon's pool and the training helpers), and they
/// run in the background while the driver advances the world and the ledger. (Under
/// `sweep --jobs N>1` the other simulations' threads are counted there too.)
#[derive(Clone, Default)]
struct Timing(std::sync::Arc<std::sync::Mutex<TimingState>>);

#[derive(Default)]
struct TimingState {
    /// The part being timed, since when (wall), and the process's and the driver thread's
    /// CPU seconds then.
    current: Option<(Part, Instant, f64, f64)>,
    /// Wall seconds (driver thread) and CPU seconds per part (see [`Timing`]).
    totals: std::collections::BTreeMap<Part, (f64, f64)>,
}

impl Profiler for Timing {
    fn switch(&mut self, part: Part) {
        let now = Instant::now();
        let cpu = process_cpu_s();
        let own = thread_cpu_s();
        let mut t = self.0.lock().expect("timing lock");
        if let Some((previous, since, cpu_since, own_since)) = t.current.take() {
            let total = t.totals.entry(previous).or_insert((0.0, 0.0));
            total.0 += now.duration_since(since).as_secs_f64();
            total.1 += own - own_since;
            let others = (cpu - cpu_since) - (own - own_since);
            t.totals.entry(Part::Learning).or_insert((0.0, 0.0)).1 += others;
        }
        t.current = Some((part, now, cpu, own));
    }
}

impl Timing {
    fn json(&self) -> serde_json::Value {
        let mut t = self.clone();
        t.switch(Part::Log);
        let t = self.0.lock().expect("timing lock");
        let wall = |p: Part| t.totals.get(&p).map_or(0.0, |v| v.0);
        let cpu = |p: Part| t.totals.get(&p).map_or(0.0, |v| v.1);
        serde_json::json!({
            "world_s": wall(Part::World),
            "ledger_s": wall(Part::Ledger),
            "learning_s": wall(Part::Learning),
            "checkpoint_s": wall(Part::Checkpoint),
            "log_and_summary_s": wall(Part::Log),
            "world_cpu_s": cpu(Part::World),
            "ledger_cpu_s": cpu(Part::Ledger),
            "learning_cpu_s": cpu(Part::Learning),
            "checkpoint_cpu_s": cpu(Part::Checkpoint),
            "log_and_summary_cpu_s": cpu(Part::Log),
        })
    }
}

/// CPU time of the whole process (all threads) in seconds; NaN if the clock is unavailable.
pub fn process_cpu_s() -> f64 {
    cpu_clock_s(libc::CLOCK_PROCESS_CPUTIME_ID)
}

/// CPU time of the calling thread in seconds; NaN if the clock is unavailable.
pub fn thread_cpu_s() -> f64 {
    cpu_clock_s(libc::CLOCK_THREAD_CPUTIME_ID)
}

fn cpu_clock_s(clock: libc::clockid_t) -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime only writes the timespec we pass.
    let rc = unsafe { libc::clock_gettime(clock, &mut ts) };
    if rc != 0 {
        return f64::NAN;
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Runs `swarmfl run`: the run into `--out` (default `runs/<preset>-seed<N>`), then its summary
/// and what to try next unless `--quiet`.
pub fn command(args: RunArgs) -> anyhow::Result<ExitCode> {
    let RunArgs {
        config,
        seed,
        out,
        quiet,
    } = args;
    let config = config.resolve()?;
    let out = out.unwrap_or_else(|| PathBuf::from(format!("runs/{}-seed{seed}", config.preset)));
    let outcome = run(config, seed, &out, quiet)?;
    if !quiet {
        print_summary(&outcome);
        print_next(&outcome);
    }
    Ok(ExitCode::SUCCESS)
}

/// What a finished run reports.
pub struct RunOutcome {
    /// The summary written to `summary.json`.
    pub summary: serde_json::Value,
    /// The log's path.
    pub log_path: PathBuf,
}

/// Runs `config` with `seed`, writing the log and summary into `out`.
pub fn run(config: Config, seed: u64, out: &Path, quiet: bool) -> anyhow::Result<RunOutcome> {
    let header = Header::new(seed, config.to_toml());
    let sim = Sim::new(config, seed)?;
    write_run(&header, sim, out, quiet, |_| Ok(()))
}

/// [`run`], interrupted at the next record once `stop` is set: the error says so, and the log
/// left in `out` is truncated (no footer, no summary). Python's Ctrl-C and a stopped sweep use it.
pub fn run_until(
    config: Config,
    seed: u64,
    out: &Path,
    quiet: bool,
    stop: &std::sync::atomic::AtomicBool,
) -> anyhow::Result<RunOutcome> {
    let header = Header::new(seed, config.to_toml());
    let sim = Sim::new(config, seed)?;
    write_run(&header, sim, out, quiet, |_| {
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            anyhow::bail!(
                "interrupted: {} is truncated (no summary); run again to redo it",
                out.join("run.swlog").display()
            );
        }
        Ok(())
    })
}

/// Drives `sim` to its end, writing `out/run.swlog` (with `header`) and `out/summary.json`;
/// `check` sees every record before it is written (a fork compares them with its parent's).
pub fn write_run(
    header: &Header,
    mut sim: Sim,
    out: &Path,
    quiet: bool,
    mut check: impl FnMut(&Record) -> anyhow::Result<()>,
) -> anyhow::Result<RunOutcome> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let log_path = out.join("run.swlog");
    let started = Instant::now();
    let seed = sim.seed();
    let mut writer = LogWriter::create(&log_path, header)?;
    let mut timing = Timing::default();
    sim.set_profiler(Box::new(timing.clone()));
    let (_, total_ms) = sim.progress();
    let label = format!("run {} seed {seed}", sim.config().preset);
    let mut progress = Progress::new(&label, "sim s", total_ms / 1000, quiet);
    while let Some(record) = sim.next() {
        timing.switch(Part::Log);
        check(&record)?;
        writer.append(&record)?;
        let (done_ms, _) = sim.progress();
        progress.set(done_ms / 1000, || {
            let rate = writer.records() as f64 / started.elapsed().as_secs_f64().max(1e-9);
            format!("{rate:.0} events/s")
        });
    }
    progress.finish(total_ms / 1000);
    let records = writer.records();
    let log_bytes = writer.bytes();
    let (footer, _) = writer.finish()?;
    let core = RunSummary::new(sim.config(), seed, sim.state(), records, footer.final_hash);
    let wall_s = started.elapsed().as_secs_f64();
    let mut summary = serde_json::to_value(&core)?;
    let map = summary.as_object_mut().expect("summary is an object");
    map.insert("wall_s".into(), serde_json::json!(wall_s));
    map.insert("log_bytes".into(), serde_json::json!(log_bytes));
    map.insert("timing".into(), timing.json());
    if let Some(gas) = evm_gas(sim.state()) {
        map.insert("evm_gas".into(), gas);
    }
    let summary_path = out.join("summary.json");
    std::fs::write(
        &summary_path,
        serde_json::to_string_pretty(&summary)? + "\n",
    )
    .with_context(|| format!("cannot write {}", summary_path.display()))?;
    Ok(RunOutcome { summary, log_path })
}

/// Without the `evm` feature no run has an EVM, so no gas to report.
#[cfg(not(feature = "evm"))]
fn evm_gas(_state: &State) -> Option<serde_json::Value> {
    None
}

/// With `contract.engine = "evm"`: the gas of the contract calls on the final canonical chain,
/// by kind (`accepted` = a submission that did not close its round, `aggregated` = the one that
/// did, `outlier`, the refusals, `deploy`), with mean, min, max and total.
#[cfg(feature = "evm")]
fn evm_gas(state: &State) -> Option<serde_json::Value> {
    let ledger = &state.ledger;
    let head = ledger.head_state(swarmfl_core::metrics::best_node(ledger));
    let evm = head.evm.as_ref()?;
    let kinds: serde_json::Map<String, serde_json::Value> = evm
        .gas
        .iter()
        .map(|(kind, g)| {
            (
                kind.clone(),
                serde_json::json!({
                    "calls": g.calls,
                    "mean_gas": g.mean_gas(),
                    "min_gas": g.min_gas,
                    "max_gas": g.max_gas,
                    "total_gas": g.total_gas,
                }),
            )
        })
        .collect();
    Some(serde_json::Value::Object(kinds))
}

/// Prints the short human summary of a run.
pub fn print_summary(outcome: &RunOutcome) {
    let s = &outcome.summary;
    println!("log:        {}", outcome.log_path.display());
    println!(
        "run:        preset {} seed {}, {} robots, {} simulated s",
        s["preset"].as_str().unwrap_or("?"),
        s["seed"],
        s["robots"],
        s["sim_time_s"]
    );
    println!("records:    {} ({} bytes)", s["records"], s["log_bytes"]);
    if let Some(world) = s.get("world") {
        println!(
            "world:      collisions {}, mean neighbours {:.2}, samples/robot/600 s {:.1}",
            world["collisions"],
            world["mean_neighbours"].as_f64().unwrap_or(0.0),
            world["samples_per_robot_per_600s"].as_f64().unwrap_or(0.0)
        );
    }
    let c = &s["contract"];
    let loss = |v: &serde_json::Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.4}"));
    let rounds = c["rounds"].as_u64().unwrap_or(0);
    let losses = c["loss_by_round"].as_array().cloned().unwrap_or_default();
    let mut shown = String::new();
    for r in [1u64, 10, 25, 50, rounds] {
        if r >= 1 && r <= rounds && !shown.contains(&format!("r{r}=")) {
            shown.push_str(&format!(" r{r}={}", loss(&losses[(r - 1) as usize])));
        }
    }
    println!("contract:   {rounds} rounds; loss by round:{shown}");
    println!(
        "            held-out loss {} -> {}; submissions {}",
        loss(&c["heldout_loss_initial"]),
        loss(&c["final_heldout_loss"]),
        c["submissions"]
    );
    println!(
        "            mean honest distance {} (outlier threshold {})",
        loss(&c["mean_honest_distance"]),
        c["outlier_threshold"]
    );
    let t = &s["tokens"];
    println!(
        "tokens:     honest mean gain {}, Byzantine mean gain {}, total units {} -> {}",
        loss(&t["honest_mean_gain"]),
        loss(&t["byzantine_mean_gain"]),
        t["total_units_start"],
        t["total_units_end"]
    );
    let a = &s["aggregation"];
    if a.is_object() {
        let mb = |v: &serde_json::Value| {
            v.as_f64()
                .map_or("-".to_string(), |x| format!("{:.3}", x / 1e6))
        };
        println!(
            "aggregation: {}; sent {} MB/robot, stored {} MB/robot; conservation {}",
            a["kind"].as_str().unwrap_or("?"),
            mb(&a["bytes_sent_per_robot_mean"]),
            mb(&a["bytes_stored_per_robot_mean"]),
            a["conservation"].as_str().unwrap_or("?")
        );
    }
    let l = &s["ledger"];
    println!(
        "ledger:     height {}, forks {}, reorgs {} (deepest {}), tx delay median {} s p95 {} s, {:.0} B/submission",
        l["canonical_height"],
        l["forks"],
        l["reorgs"],
        l["deepest_reorg"],
        l["tx_delay_median_s"],
        l["tx_delay_p95_s"],
        l["bytes_per_submission"].as_f64().unwrap_or(0.0)
    );
    if let Some(gas) = s.get("evm_gas") {
        let mean = |kind: &str| {
            gas[kind]["mean_gas"]
                .as_u64()
                .map_or("-".into(), |g| g.to_string())
        };
        println!(
            "evm gas:    submission {} (mean), aggregating submission {}, outlier {}, deploy {}; \
             contract wall time is inside ledger_s below",
            mean("accepted"),
            mean("aggregated"),
            mean("outlier"),
            mean("deploy")
        );
    }
    println!("timing:     {}", s["timing"]);
    println!("final hash: {}", s["final_hash"].as_str().unwrap_or("?"));
    println!("wall time:  {:.2} s", s["wall_s"].as_f64().unwrap_or(0.0));
}

/// Prints what to do next with a finished run's log.
pub fn print_next(outcome: &RunOutcome) {
    let log = outcome.log_path.display();
    let html = outcome.log_path.with_file_name("run.html");
    let height = outcome.summary["ledger"]["canonical_height"]
        .as_u64()
        .unwrap_or(0)
        / 2;
    println!();
    println!("next:");
    println!(
        "  swarmfl view {log} --out {}   # watch it in a browser",
        html.display()
    );
    println!("  swarmfl replay {log}            # check that it replays bit-exactly");
    println!(
        "  swarmfl inspect {log} --block {height}   # the chain, contract and robots at a block"
    );
}

//! `swarmfl run`: simulate a run into `DIR/run.swlog` and `DIR/summary.json`.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context;
use swarmfl_core::byzantine::plugin::Plugins;
use swarmfl_core::config::{Aggregation, Config};
use swarmfl_core::event::{CheckpointCause, Record};
use swarmfl_core::log::{Header, LogWriter};
use swarmfl_core::sim::{Part, Profiler, Sim, DEFAULT_LOOKAHEAD_MS};
use swarmfl_core::state::State;
use swarmfl_core::summary::RunSummary;

use crate::cli::RunArgs;
use crate::progress::Progress;
use crate::run_dir;

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

/// Runs `swarmfl run`: the run into `--out` (default [`run_dir::default_run_dir`]: distinct
/// per configuration), then its summary and what to try next unless `--quiet`. A run already in
/// the folder is replaced or refused as [`run_dir::prepare`] says.
pub fn command(args: RunArgs) -> anyhow::Result<ExitCode> {
    let RunArgs {
        config: config_args,
        seed,
        out,
        force,
        quiet,
        live,
        port,
    } = args;
    let config = config_args.resolve()?;
    let (out, chosen) = run_dir::choose(out, force, || {
        // The file was read once by `resolve`; a second read that fails says so.
        let file = match &config_args.config {
            Some(path) => Some(
                std::fs::read(path)
                    .with_context(|| format!("cannot read --config {}", path.display()))?,
            ),
            None => None,
        };
        Ok(run_dir::default_run_dir(
            &config.preset,
            seed,
            &config_args.overrides,
            file.as_deref(),
        ))
    })?;
    if let Some(warning) = density_warning(&config) {
        eprintln!("{warning}");
    }
    // Bound before the previous run is cleared: a port in use changes nothing on disk.
    let server = match live {
        true => Some(crate::commands::live::Live::bind(port)?),
        false => None,
    };
    if let Some(replaced) = run_dir::prepare(&out, &run_header(&config, seed), chosen)? {
        eprintln!("{replaced}");
    }
    let outcome = match server {
        None => run(config, seed, &out, quiet)?,
        Some(server) => {
            let live = server.start(&out.join("run.swlog"));
            eprintln!(
                "live view: {} (while the run goes; Ctrl-C stops the run and the view)",
                live.url()
            );
            let never = std::sync::atomic::AtomicBool::new(false);
            let outcome = run_with(config, seed, &out, quiet, &never, LIVE_FLUSH);
            // Whether the run ended or failed, the page gets the log as it is and says so.
            live.finish();
            outcome?
        }
    };
    if !quiet {
        print_summary(&outcome);
        print_next(&outcome);
    }
    Ok(ExitCode::SUCCESS)
}

/// The header of a run of `config` with `seed` offered no plug-ins (the command line's): what
/// [`run_with_plugins`] writes, and what a run already in the folder is compared with.
fn run_header(config: &Config, seed: u64) -> Header {
    Header::new(seed, config.to_toml())
}

/// Neighbours within radio range above which `run` says the swarm is crowded (the paper's
/// robots have about 5 by `world.mean_neighbours`; the formula gives 7 before obstacles).
const CROWDED_NEIGHBOURS: f64 = 100.0;

/// A word when the swarm is so dense that every robot hears a crowd: the expected neighbours
/// in range, what every message and range reading scales with, is `(robots - 1) * P` with `P`
/// the chance that two points placed uniformly in the square arena lie within the range `r`:
/// `pi t^2 - 8/3 t^3 + t^4 / 2` for `t = r / side <= 1` (edges included; `t` is capped at 1,
/// where the formula is still within 3 % of the exact 1). `None` below [`CROWDED_NEIGHBOURS`].
fn density_warning(config: &Config) -> Option<String> {
    let w = &config.world;
    let t = (w.rab_range_m / w.arena_side_m).min(1.0);
    let share = std::f64::consts::PI * t * t - 8.0 / 3.0 * t * t * t + t * t * t * t / 2.0;
    let neighbours = f64::from(w.robots.saturating_sub(1)) * share;
    (neighbours > CROWDED_NEIGHBOURS).then(|| {
        format!(
            "note: {} robots in a {} x {} m arena with {} m radio range: about {neighbours:.0} \
             neighbours each (the `paper` preset's robots have about 5), so every tick, message and reading \
             costs that much more; to keep the paper's density, scale `world.arena_side_m` by \
             sqrt(robots / 15) (as `bench scale` does)",
            w.robots, w.arena_side_m, w.arena_side_m, w.rab_range_m
        )
    })
}

/// What a finished run reports.
pub struct RunOutcome {
    /// The summary written to `summary.json`.
    pub summary: serde_json::Value,
    /// The log's path.
    pub log_path: PathBuf,
    /// Blocks sealed by any node on any fork (genesis apart): the log's block checkpoints,
    /// what `replay`, `view` and `export` count as sealings.
    pub sealings: u64,
}

/// Runs `config` with `seed`, writing the log and summary into `out`.
pub fn run(config: Config, seed: u64, out: &Path, quiet: bool) -> anyhow::Result<RunOutcome> {
    // [`run_until`] with a flag nobody sets: one path from configuration to log.
    let never = std::sync::atomic::AtomicBool::new(false);
    run_until(config, seed, out, quiet, &never)
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
    run_with(config, seed, out, quiet, stop, Flush::WhenFull)
}

/// How far behind the run the live view's reader of the log may fall: the log is flushed at
/// the first record after this much wall time.
const LIVE_FLUSH: Flush = Flush::Every(Duration::from_millis(250));

/// [`run_until`] with the log flushed as `flush` says (the bytes are the same either way).
pub fn run_with(
    config: Config,
    seed: u64,
    out: &Path,
    quiet: bool,
    stop: &std::sync::atomic::AtomicBool,
    flush: Flush,
) -> anyhow::Result<RunOutcome> {
    run_with_plugins(config, seed, out, quiet, &Plugins::none(), flush, || {
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            anyhow::bail!(
                "interrupted: {} is truncated (no summary); run again to redo it",
                out.join("run.swlog").display()
            );
        }
        Ok(())
    })
}

/// [`run_until`] offered `plugins` (the Python package's attacks): the header records the ones
/// the configuration uses; `check` runs before every record is written, and its error stops
/// the run (a plug-in that failed, Ctrl-C), leaving the log truncated.
pub fn run_with_plugins(
    config: Config,
    seed: u64,
    out: &Path,
    quiet: bool,
    plugins: &Plugins,
    flush: Flush,
    mut check: impl FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<RunOutcome> {
    let mut header = run_header(&config, seed);
    header.plugins = plugins.used_by(&config).map_err(anyhow::Error::msg)?;
    let sim = Sim::with_plugins(config, seed, DEFAULT_LOOKAHEAD_MS, plugins)?;
    write_run(&header, sim, out, quiet, flush, |_| check())
}

/// When the log's buffered bytes reach its file while a run goes. Either way the file ends
/// with the same bytes: only when a reader of the growing file sees them changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flush {
    /// When the 1 MB buffer is full, and at the end: the fewest writes.
    WhenFull,
    /// Also at the first write after this much wall time since the last flush, so a reader of
    /// the growing log (the live view) is never further behind than that.
    Every(Duration),
}

/// The log's file behind a 1 MB buffer, flushed as a [`Flush`] says.
struct LogFile {
    out: BufWriter<File>,
    every: Option<Duration>,
    last: Instant,
}

impl Write for LogFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.out.write(buf)?;
        if let Some(every) = self.every {
            if self.last.elapsed() >= every {
                self.out.flush()?;
                self.last = Instant::now();
            }
        }
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// Drives `sim` to its end, writing `out/run.swlog` (with `header`, flushed as `flush` says)
/// and `out/summary.json`; `check` sees every record before it is written (a fork compares
/// them with its parent's).
pub fn write_run(
    header: &Header,
    mut sim: Sim,
    out: &Path,
    quiet: bool,
    flush: Flush,
    mut check: impl FnMut(&Record) -> anyhow::Result<()>,
) -> anyhow::Result<RunOutcome> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let log_path = out.join("run.swlog");
    let started = Instant::now();
    let seed = sim.seed();
    let file = File::create(&log_path)
        .with_context(|| format!("cannot create the log {}", log_path.display()))?;
    let file = LogFile {
        out: BufWriter::with_capacity(1 << 20, file),
        every: match flush {
            Flush::WhenFull => None,
            Flush::Every(every) => Some(every),
        },
        last: started,
    };
    let mut writer = LogWriter::new(file, &log_path.display().to_string(), header)?;
    let mut timing = Timing::default();
    sim.set_profiler(Box::new(timing.clone()));
    let (_, total_ms) = sim.progress();
    let label = format!("run {} seed {seed}", sim.config().preset);
    let mut progress = Progress::new(&label, "sim s", total_ms / 1000, quiet);
    let mut sealings = 0;
    while let Some(record) = sim.next() {
        timing.switch(Part::Log);
        check(&record)?;
        if let Record::Checkpoint(cp) = &record {
            if matches!(cp.cause, CheckpointCause::Block { .. }) {
                sealings += 1;
            }
        }
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
    Ok(RunOutcome {
        summary,
        log_path,
        sealings,
    })
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

/// Prints the short human summary of a run ([`summary_text`]).
pub fn print_summary(outcome: &RunOutcome) {
    print!(
        "{}",
        summary_text(&outcome.summary, &outcome.log_path, outcome.sealings)
    );
}

/// How the run's models were aggregated, from its summary (`chain` when it does not say: the
/// summaries written before the baselines).
fn aggregation_kind(summary: &serde_json::Value) -> Aggregation {
    serde_json::from_value(summary["aggregation"]["kind"].clone()).unwrap_or_default()
}

/// A loss as `run` prints it: four decimals, `-` when there is none.
fn loss(v: &serde_json::Value) -> String {
    v.as_f64().map_or("-".to_string(), |x| format!("{x:.4}"))
}

/// Megabytes with three decimals, `-` when there are none.
fn mb(v: &serde_json::Value) -> String {
    v.as_f64()
        .map_or("-".to_string(), |x| format!("{:.3}", x / 1e6))
}

/// The losses at aggregations 1, 10, 25, 50 and the last, as ` {p}1=... {p}10=...`.
fn loss_points(contract: &serde_json::Value, prefix: &str) -> String {
    let rounds = contract["rounds"].as_u64().unwrap_or(0);
    let losses = contract["loss_by_round"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let mut shown = String::new();
    for r in [1u64, 10, 25, 50, rounds] {
        let label = format!("{prefix}{r}=");
        if r >= 1 && r <= rounds && !shown.contains(&format!(" {label}")) {
            let value = losses
                .get((r - 1) as usize)
                .unwrap_or(&serde_json::Value::Null);
            shown.push_str(&format!(" {label}{}", loss(value)));
        }
    }
    match shown.is_empty() {
        true => " -".to_string(),
        false => shown,
    }
}

/// The short human summary of a run (`summary` as in `summary.json`, its log at `log`,
/// `sealings` blocks sealed on all forks): what every run has, then the contract, tokens and
/// ledger of a chain run or the aggregations and traffic of a baseline (which has no chain,
/// contract or tokens), then timing and the final hash.
pub fn summary_text(summary: &serde_json::Value, log: &Path, sealings: u64) -> String {
    let s = summary;
    let kind = aggregation_kind(s);
    let mut out = vec![
        format!("log:        {}", log.display()),
        format!(
            "run:        preset {} seed {}, {} robots, {} simulated s",
            s["preset"].as_str().unwrap_or("?"),
            s["seed"],
            s["robots"],
            s["sim_time_s"]
        ),
        format!("records:    {} ({} bytes)", s["records"], s["log_bytes"]),
    ];
    if let Some(world) = s.get("world") {
        out.push(format!(
            "world:      collisions {}, mean neighbours {:.2}, samples/robot/600 s {:.1}",
            world["collisions"],
            world["mean_neighbours"].as_f64().unwrap_or(0.0),
            world["samples_per_robot_per_600s"].as_f64().unwrap_or(0.0)
        ));
    }
    match kind {
        Aggregation::Chain => chain_lines(s, sealings, &mut out),
        Aggregation::Gossip => gossip_lines(s, &mut out),
        Aggregation::Central => central_lines(s, &mut out),
    }
    if let Some(gas) = s.get("evm_gas") {
        let mean = |kind: &str| {
            gas[kind]["mean_gas"]
                .as_u64()
                .map_or("-".into(), |g| g.to_string())
        };
        out.push(format!(
            "evm gas:    submission {} (mean), aggregating submission {}, outlier {}, deploy {}; \
             contract wall time is inside ledger_s below",
            mean("accepted"),
            mean("aggregated"),
            mean("outlier"),
            mean("deploy")
        ));
    }
    out.push(format!("timing:     {}", timing_line(&s["timing"], kind)));
    out.push(format!(
        "final hash: {}",
        s["final_hash"].as_str().unwrap_or("?")
    ));
    out.push(format!(
        "wall time:  {:.2} s",
        s["wall_s"].as_f64().unwrap_or(0.0)
    ));
    out.join("\n") + "\n"
}

/// A chain run's contract, tokens, aggregation traffic and ledger.
fn chain_lines(s: &serde_json::Value, sealings: u64, out: &mut Vec<String>) {
    let c = &s["contract"];
    out.push(format!(
        "contract:   {} rounds; loss by round:{}",
        c["rounds"].as_u64().unwrap_or(0),
        loss_points(c, "r")
    ));
    out.push(format!(
        "            held-out loss {} -> {}; submissions {}",
        loss(&c["heldout_loss_initial"]),
        loss(&c["final_heldout_loss"]),
        c["submissions"]
    ));
    out.push(format!(
        "            mean honest distance {} (outlier threshold {})",
        loss(&c["mean_honest_distance"]),
        c["outlier_threshold"]
    ));
    let t = &s["tokens"];
    out.push(format!(
        "tokens:     honest mean gain {}, Byzantine mean gain {}, total units {} -> {}",
        loss(&t["honest_mean_gain"]),
        loss(&t["byzantine_mean_gain"]),
        t["total_units_start"],
        t["total_units_end"]
    ));
    if let Some(held) = t["contract_holdings"].as_f64().filter(|h| *h > 0.0) {
        // Without this a clean run's negative gain reads as a loss: it is stake still locked.
        out.push(format!(
            "            (gains count {held:.3} tokens as spent: the stakes the contract still \
             holds for the round open at the end)"
        ));
    }
    let a = &s["aggregation"];
    if a.is_object() {
        out.push(format!(
            "aggregation: {}; sent {} MB/robot, stored {} MB/robot; conservation {}",
            a["kind"].as_str().unwrap_or("?"),
            mb(&a["bytes_sent_per_robot_mean"]),
            mb(&a["bytes_stored_per_robot_mean"]),
            a["conservation"].as_str().unwrap_or("?")
        ));
    }
    let l = &s["ledger"];
    out.push(format!(
        "ledger:     canonical height {} (blocks of the final chain, genesis apart), {} \
         sealings on all forks (every block any node sealed, as `replay`, `view` and `export` \
         count them), forks {}, reorgs {} (deepest {}), tx delay median {} s p95 {} s, {:.0} \
         B/submission",
        l["canonical_height"],
        sealings,
        l["forks"],
        l["reorgs"],
        l["deepest_reorg"],
        l["tx_delay_median_s"],
        l["tx_delay_p95_s"],
        l["bytes_per_submission"].as_f64().unwrap_or(0.0)
    ));
}

/// What a baseline's summary says about the models it averaged: `N honest and M Byzantine
/// models averaged`, and the models written (`accepted`, with the duplicates dropped if any).
/// The summary's `contract` section holds a baseline's figures under the chain's names.
fn baseline_models(c: &serde_json::Value) -> (String, String) {
    let averaged = format!(
        "{} honest and {} Byzantine models averaged",
        c["aggregated_honest"].as_u64().unwrap_or(0),
        c["aggregated_byzantine"].as_u64().unwrap_or(0)
    );
    let submissions = &c["submissions"];
    let mut written = submissions["accepted"].as_u64().unwrap_or(0).to_string();
    if let Some(d) = submissions["duplicate"].as_u64().filter(|d| *d > 0) {
        written.push_str(&format!(" ({d} duplicates dropped)"));
    }
    (averaged, written)
}

/// A gossip run's merges (of honest robots), the models they averaged, the held-out loss of
/// the honest robots' final models and the radio's bytes and messages. No chain, contract or
/// tokens exist here, so none are shown.
fn gossip_lines(s: &serde_json::Value, out: &mut Vec<String>) {
    let (c, a) = (&s["contract"], &s["aggregation"]);
    let (averaged, written) = baseline_models(c);
    out.push(
        "aggregation: gossip (Flow-FL: a virtual-stigmergy store shared by neighbour gossip; no \
         chain, contract or tokens)"
            .to_string(),
    );
    out.push(format!(
        "merges:     {} by honest robots, {averaged}; loss by merge:{}",
        c["rounds"].as_u64().unwrap_or(0),
        loss_points(c, "#")
    ));
    out.push(format!(
        "            held-out loss {} -> {} (mean over the honest robots' final models); models \
         written {written}",
        loss(&c["heldout_loss_initial"]),
        loss(&c["final_heldout_loss"]),
    ));
    out.push(format!(
        "radio:      sent {} MB/robot, stored {} MB/robot (its replica); messages {} sent, {} \
         lost",
        mb(&a["bytes_sent_per_robot_mean"]),
        mb(&a["bytes_stored_per_robot_mean"]),
        a["messages_sent"],
        a["messages_lost"]
    ));
}

/// A central run's server aggregations (each a model version), the models they averaged, the
/// held-out loss of the server's model and the bytes uploaded, downloaded and stored. No
/// chain, contract or tokens exist here, so none are shown.
fn central_lines(s: &serde_json::Value, out: &mut Vec<String>) {
    let (c, a) = (&s["contract"], &s["aggregation"]);
    let (averaged, written) = baseline_models(c);
    let versions = c["rounds"].as_u64().unwrap_or(0);
    out.push(
        "aggregation: central (an ideal server: FedAvg of every upload; no chain, contract or \
         tokens)"
            .to_string(),
    );
    out.push(format!(
        "server:     {versions} aggregations (model versions 1..{versions}), {averaged}; loss \
         by version:{}",
        loss_points(c, "v")
    ));
    out.push(format!(
        "            held-out loss {} -> {} (the server's model); uploads {written}",
        loss(&c["heldout_loss_initial"]),
        loss(&c["final_heldout_loss"]),
    ));
    out.push(format!(
        "traffic:    uploaded {} MB/robot, downloaded {} MB/robot, stored {} MB/robot",
        mb(&a["bytes_sent_per_robot_mean"]),
        mb(&a["bytes_downloaded_per_robot_mean"]),
        mb(&a["bytes_stored_per_robot_mean"])
    ));
}

/// The `timing` object of a summary as one line of seconds, wall (CPU): the parts in the
/// order they run, each `name W s (C s CPU)`; `summary.json` keeps the full numbers. The
/// driver's ledger part is a baseline's aggregation protocol (`kind`), and is named so.
fn timing_line(timing: &serde_json::Value, kind: Aggregation) -> String {
    let Some(map) = timing.as_object() else {
        return "-".to_string();
    };
    let protocol = match kind {
        Aggregation::Chain => "ledger",
        Aggregation::Gossip | Aggregation::Central => "aggregation",
    };
    let mut parts = Vec::new();
    for (name, label) in [
        ("world", "world"),
        ("ledger", protocol),
        ("learning", "learning"),
        ("checkpoint", "checkpoints"),
        ("log_and_summary", "log"),
    ] {
        let wall = map.get(&format!("{name}_s")).and_then(|v| v.as_f64());
        let cpu = map.get(&format!("{name}_cpu_s")).and_then(|v| v.as_f64());
        if let Some(wall) = wall {
            parts.push(match cpu {
                Some(cpu) => format!("{label} {wall:.2} s ({cpu:.2} s CPU)"),
                None => format!("{label} {wall:.2} s"),
            });
        }
    }
    parts.join(", ")
}

/// Prints what to do next with a finished run's log, with the command spelled the way this
/// shell can run it (see [`program_name`]).
pub fn print_next(outcome: &RunOutcome) {
    let me = program_name();
    print!("{}", next_text(&outcome.summary, &outcome.log_path, &me));
    if me != "swarmfl" {
        println!("  (`cargo install --path replay-cli --locked` puts `swarmfl` on your PATH)");
    }
}

/// What to do next with the run of `summary` logged at `log`, spelled with the program `me`:
/// view, replay, and inspect halfway through: at the block halfway up the final chain, or for
/// a baseline (no blocks) at half its simulated time.
pub fn next_text(summary: &serde_json::Value, log: &Path, me: &str) -> String {
    let html = log.with_file_name("run.html");
    let log = log.display();
    let inspect = match aggregation_kind(summary) {
        Aggregation::Chain => {
            let height = summary["ledger"]["canonical_height"].as_u64().unwrap_or(0) / 2;
            format!(
                "{me} inspect {log} --block {height}   # the chain, contract and robots at a block"
            )
        }
        Aggregation::Gossip | Aggregation::Central => {
            let half_s = (summary["sim_time_s"].as_f64().unwrap_or(0.0) / 2.0).floor();
            format!(
                "{me} inspect {log} --time {half_s}   # the models, losses and bytes at a time (no \
                 chain: no blocks)"
            )
        }
    };
    format!(
        "\nnext:\n  {me} view {log} --out {}   # watch it in a browser\n  {me} replay {log}            \
         # check its hash chain and checkpoints (--resimulate: re-make every record)\n  {inspect}\n",
        html.display()
    )
}

/// `swarmfl` when that name on the PATH is this very program, else the path this process was
/// started by (`target/release/swarmfl` under `cargo run`), so every hint can be pasted as is.
fn program_name() -> String {
    let me = std::env::current_exe()
        .ok()
        .and_then(|p| p.canonicalize().ok());
    let on_path = std::env::var_os("PATH").is_some_and(|paths| {
        std::env::split_paths(&paths).any(|dir| {
            let candidate = dir.join("swarmfl").canonicalize().ok();
            candidate.is_some() && candidate == me
        })
    });
    if on_path {
        return "swarmfl".to_string();
    }
    std::env::args()
        .next()
        .filter(|a| a.contains('/'))
        .or_else(|| me.map(|p| p.display().to_string()))
        .unwrap_or_else(|| "swarmfl".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_crowded_swarm_is_named_and_the_papers_is_not() {
        let mut config = swarmfl_core::config::Preset::Paper.config();
        assert_eq!(density_warning(&config), None);
        config.world.robots = 2000;
        let warning = density_warning(&config).expect("2000 robots in 5 x 5 m is crowded");
        assert!(warning.contains("about 966 neighbours each"), "{warning}");
    }

    /// A summary as `summary.json` holds it (the figures of a 600 s smoke run) with the
    /// aggregation `kind`'s own figures.
    fn summary(kind: &str) -> serde_json::Value {
        let baseline = kind != "chain";
        serde_json::json!({
            "preset": "smoke", "seed": 7, "robots": 15, "sim_time_s": 600.0,
            "records": 8743, "log_bytes": 1902139,
            "world": {"collisions": 0, "mean_neighbours": 4.38,
                      "samples_per_robot_per_600s": 230.4},
            "contract": {
                "rounds": if baseline { 12 } else { 34 },
                "loss_by_round": vec![1.75; if baseline { 12 } else { 34 }],
                "heldout_loss_initial": 3.0719, "final_heldout_loss": 2.0781,
                "submissions": if baseline {
                    serde_json::json!({"accepted": 87, "duplicate": 2})
                } else {
                    serde_json::json!({"accepted": 80, "outlier": 3})
                },
                "mean_honest_distance": if baseline { serde_json::Value::Null } else { 0.01.into() },
                "outlier_threshold": 0.05, "aggregated_honest": 84, "aggregated_byzantine": 1,
            },
            "tokens": {"honest_mean_gain": 0.0, "byzantine_mean_gain": null,
                       "total_units_start": 315, "total_units_end": 315},
            "aggregation": {
                "kind": kind, "conservation": "not applicable",
                "bytes_sent_per_robot_mean": 1157000.0, "bytes_stored_per_robot_mean": 214000.0,
                "bytes_downloaded_per_robot_mean": 85000.0,
                "messages_sent": 4321, "messages_lost": 12,
            },
            "ledger": {"canonical_height": if baseline { 0 } else { 34 }, "forks": 0,
                       "reorgs": 0, "deepest_reorg": 0, "tx_delay_median_s": 0.0,
                       "tx_delay_p95_s": 0.0, "bytes_per_submission": 0.0},
            "timing": {"world_s": 0.15, "ledger_s": 0.06},
            "final_hash": "f7182768053f1de713500eb01b33fef473e1f9577f1e33703a501c9a8476a708",
            "wall_s": 2.66,
        })
    }

    /// The summary and the next steps of `kind`'s summary, as `run` prints them.
    fn printed(kind: &str) -> String {
        let log = Path::new("runs/x/run.swlog");
        summary_text(&summary(kind), log, 0) + &next_text(&summary(kind), log, "swarmfl")
    }

    #[test]
    fn a_baselines_summary_says_what_it_has_and_nothing_of_a_chain() {
        for kind in ["gossip", "central"] {
            let text = printed(kind);
            for chain_only in [
                "contract:",
                "rounds",
                "tokens:",
                "canonical height",
                "--block",
                "ledger",
            ] {
                assert!(
                    !text.contains(chain_only),
                    "{kind}: {chain_only} in\n{text}"
                );
            }
            assert!(text.contains("no chain, contract or tokens"), "{text}");
            assert!(
                text.contains("84 honest and 1 Byzantine models averaged"),
                "{text}"
            );
            assert!(text.contains("held-out loss 3.0719 -> 2.0781"), "{text}");
            assert!(text.contains("87 (2 duplicates dropped)"), "{text}");
            assert!(
                text.contains("timing:     world 0.15 s, aggregation 0.06 s"),
                "{text}"
            );
            assert!(
                text.contains("swarmfl inspect runs/x/run.swlog --time 300   #"),
                "{text}"
            );
        }
        let gossip = printed("gossip");
        assert!(gossip.contains("aggregation: gossip (Flow-FL"), "{gossip}");
        assert!(
            gossip.contains("merges:     12 by honest robots"),
            "{gossip}"
        );
        assert!(
            gossip.contains("loss by merge: #1=1.7500 #10=1.7500 #12=1.7500"),
            "{gossip}"
        );
        assert!(
            gossip.contains("radio:      sent 1.157 MB/robot, stored 0.214 MB/robot (its replica); messages 4321 sent, 12 lost"),
            "{gossip}"
        );
        let central = printed("central");
        assert!(
            central.contains("server:     12 aggregations (model versions 1..12)"),
            "{central}"
        );
        assert!(
            central.contains("traffic:    uploaded 1.157 MB/robot, downloaded 0.085 MB/robot, stored 0.214 MB/robot"),
            "{central}"
        );
    }

    #[test]
    fn a_chain_runs_summary_keeps_its_contract_tokens_and_ledger() {
        let text = printed("chain");
        assert!(
            text.contains(
                "contract:   34 rounds; loss by round: r1=1.7500 r10=1.7500 r25=1.7500 r34=1.7500"
            ),
            "{text}"
        );
        assert!(
            text.contains("tokens:     honest mean gain 0.0000"),
            "{text}"
        );
        assert!(text.contains("ledger:     canonical height 34"), "{text}");
        assert!(
            text.contains("timing:     world 0.15 s, ledger 0.06 s"),
            "{text}"
        );
        assert!(
            text.contains("swarmfl inspect runs/x/run.swlog --block 17   #"),
            "{text}"
        );
        // A summary from before the baselines has no aggregation section: a chain run's.
        let mut old = summary("chain");
        old.as_object_mut().unwrap().remove("aggregation");
        let text = summary_text(&old, Path::new("run.swlog"), 0);
        assert!(text.contains("canonical height 34"), "{text}");
    }

    #[test]
    fn timing_reads_as_seconds_in_the_order_the_parts_run() {
        let timing = serde_json::json!({
            "world_s": 1.5130919520000006, "world_cpu_s": 1.4992536579999949,
            "learning_s": 16.93136347900006, "learning_cpu_s": 30.87294149599976,
        });
        assert_eq!(
            timing_line(&timing, Aggregation::Chain),
            "world 1.51 s (1.50 s CPU), learning 16.93 s (30.87 s CPU)"
        );
    }
}

//! A run: simulate a configuration into `DIR/run.swlog` and `DIR/summary.json`, the one path
//! from configuration to log that `swarmfl run`, `fork`, `sweep`, `fixtures`, `bench` and the
//! Python package take.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use swarmfl_core::byzantine::plugin::Plugins;
use swarmfl_core::config::Config;
use swarmfl_core::event::{CheckpointCause, Record};
use swarmfl_core::log::{Header, LogWriter};
use swarmfl_core::sim::{Part, Profiler, Sim, DEFAULT_LOOKAHEAD_MS};
use swarmfl_core::state::State;
use swarmfl_core::summary::RunSummary;

use crate::progress::Watch;
use crate::summary::{self, Summary};

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
    fn summary(&self) -> summary::Timing {
        let mut t = self.clone();
        t.switch(Part::Log);
        let t = self.0.lock().expect("timing lock");
        let wall = |p: Part| t.totals.get(&p).map_or(0.0, |v| v.0);
        let cpu = |p: Part| t.totals.get(&p).map_or(0.0, |v| v.1);
        summary::Timing {
            world_s: wall(Part::World),
            ledger_s: wall(Part::Ledger),
            learning_s: wall(Part::Learning),
            checkpoint_s: wall(Part::Checkpoint),
            log_and_summary_s: wall(Part::Log),
            world_cpu_s: cpu(Part::World),
            ledger_cpu_s: cpu(Part::Ledger),
            learning_cpu_s: cpu(Part::Learning),
            checkpoint_cpu_s: cpu(Part::Checkpoint),
            log_and_summary_cpu_s: cpu(Part::Log),
        }
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

/// The header of a run of `config` with `seed` offered no plug-ins (the command line's): what
/// [`RunRequest::run`] writes, and what a run already in the folder is compared with.
pub fn run_header(config: &Config, seed: u64) -> Header {
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
pub fn density_warning(config: &Config) -> Option<String> {
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
    pub summary: Summary,
    /// The log's path.
    pub log_path: PathBuf,
    /// Blocks sealed by any node on any fork (genesis apart): the log's block checkpoints,
    /// what `replay`, `view` and `export` count as sealings.
    pub sealings: u64,
}

/// A run to make: a configuration and a seed into a folder, and how. The one path from a
/// configuration to a log and its summary that `swarmfl run`, `sweep`, `recheck`, `fixtures`,
/// `bench` and the Python package take:
/// `RunRequest::new(config, seed, out).stop(&flag).run(&watch)`.
pub struct RunRequest<'a> {
    config: Config,
    seed: u64,
    out: &'a Path,
    plugins: Option<&'a Plugins>,
    flush: Flush,
    stop: Option<&'a AtomicBool>,
}

impl<'a> RunRequest<'a> {
    /// A run of `config` with `seed` into `out` (`run.swlog`, `summary.json`): no plug-ins,
    /// the log flushed when its buffer is full, never stopped.
    pub fn new(config: Config, seed: u64, out: &'a Path) -> RunRequest<'a> {
        RunRequest {
            config,
            seed,
            out,
            plugins: None,
            flush: Flush::WhenFull,
            stop: None,
        }
    }

    /// Offers `plugins` (the Python package's attacks and rules): the header records the ones
    /// the configuration uses.
    pub fn plugins(mut self, plugins: &'a Plugins) -> RunRequest<'a> {
        self.plugins = Some(plugins);
        self
    }

    /// Flushes the log as `flush` says (the bytes are the same either way).
    pub fn flush(mut self, flush: Flush) -> RunRequest<'a> {
        self.flush = flush;
        self
    }

    /// Stops the run at the next record once `stop` is set: the error says so, and the log
    /// left in the folder is truncated (no footer, no summary). Ctrl-C and a stopped sweep.
    pub fn stop(mut self, stop: &'a AtomicBool) -> RunRequest<'a> {
        self.stop = Some(stop);
        self
    }

    /// Makes the run, its progress and warnings on `watch`.
    pub fn run(self, watch: &dyn Watch) -> anyhow::Result<RunOutcome> {
        self.run_checked(watch, || Ok(()))
    }

    /// [`RunRequest::run`] with `check` run before every record is written: its error stops
    /// the run (a plug-in that failed, Ctrl-C seen by the caller), leaving the log truncated.
    pub fn run_checked(
        self,
        watch: &dyn Watch,
        mut check: impl FnMut() -> anyhow::Result<()>,
    ) -> anyhow::Result<RunOutcome> {
        let RunRequest {
            config,
            seed,
            out,
            plugins,
            flush,
            stop,
        } = self;
        let none = Plugins::none();
        let plugins = plugins.unwrap_or(&none);
        let mut header = run_header(&config, seed);
        header.plugins = plugins.used_by(&config).map_err(anyhow::Error::msg)?;
        let sim = Sim::with_plugins(config, seed, DEFAULT_LOOKAHEAD_MS, plugins)?;
        write_run(&header, sim, out, watch, flush, |_| {
            if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
                anyhow::bail!(
                    "interrupted: {} is truncated (no summary); run again to redo it",
                    out.join("run.swlog").display()
                );
            }
            check()
        })
    }
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
    watch: &dyn Watch,
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
    let mut progress = watch.start(&label, "sim s", total_ms / 1000);
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
        progress.set(done_ms / 1000, &|| {
            let rate = writer.records() as f64 / started.elapsed().as_secs_f64().max(1e-9);
            format!("{rate:.0} events/s")
        });
    }
    progress.finish(total_ms / 1000);
    let records = writer.records();
    let log_bytes = writer.bytes();
    let (footer, _) = writer.finish()?;
    let mut core = RunSummary::new(sim.config(), seed, sim.state(), records, footer.final_hash);
    core.world.position_heterogeneity = Some(sim.position_heterogeneity());
    let wall_s = started.elapsed().as_secs_f64();
    let summary = Summary {
        run: core,
        wall_s,
        log_bytes,
        timing: timing.summary(),
        evm_gas: evm_gas(sim.state()),
    };
    let summary_path = out.join("summary.json");
    std::fs::write(&summary_path, summary::to_json(&summary)?)
        .with_context(|| format!("cannot write {}", summary_path.display()))?;
    Ok(RunOutcome {
        summary,
        log_path,
        sealings,
    })
}

/// Without the `evm` feature no run has an EVM, so no gas to report.
#[cfg(not(feature = "evm"))]
fn evm_gas(_state: &State) -> Option<std::collections::BTreeMap<String, summary::EvmGas>> {
    None
}

/// With `contract.engine = "evm"`: the gas of the contract calls on the final canonical chain,
/// by kind (`accepted` = a submission that did not close its round, `aggregated` = the one that
/// did, `outlier`, the refusals, `deploy`), with mean, min, max and total.
#[cfg(feature = "evm")]
fn evm_gas(state: &State) -> Option<std::collections::BTreeMap<String, summary::EvmGas>> {
    let ledger = &state.ledger;
    let head = ledger.head_state(swarmfl_core::metrics::best_node(ledger));
    let evm = head.evm.as_ref()?;
    let kinds = evm
        .gas
        .iter()
        .map(|(kind, g)| {
            (
                kind.clone(),
                summary::EvmGas {
                    calls: g.calls,
                    mean_gas: g.mean_gas(),
                    min_gas: g.min_gas,
                    max_gas: g.max_gas,
                    total_gas: g.total_gas,
                },
            )
        })
        .collect();
    Some(kinds)
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
}

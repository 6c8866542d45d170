//! The PyO3 functions and classes of `swarmfl._swarmfl` (see `swarmfl/__init__.py` for the
//! Python API built on them).
//!
//! Every error becomes a `swarmfl.SwarmflError` whose message is the command's (`error: ...`
//! without the prefix): a bad key, a missing or damaged log, a bad expression. A simulation
//! runs with the interpreter released (other Python threads go on).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Mutex};
use std::time::Duration;

use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyList};
use swarmfl_core::config::{Aggregation, Config};
use swarmfl_core::inspect::{self, timeline, Column, Expr, RunIndex, Table};
use swarmfl_core::types::SimTime;
use swarmfl_study::progress::Quiet;
use swarmfl_study::run::RunRequest;
use swarmfl_study::run_dir::Chosen;
use swarmfl_study::sweep::{Shard, SweepOptions, TaskDone};

use crate::plugins;
use crate::watch::Lines;

pyo3::create_exception!(
    _swarmfl,
    SwarmflError,
    PyException,
    "An error of swarmfl: the message is the `swarmfl` command's for the same input."
);

/// The Python exception of an error, with the command's message.
fn err(e: impl Into<anyhow::Error>) -> PyErr {
    let e: anyhow::Error = e.into();
    SwarmflError::new_err(format!("{e:#}"))
}

/// A table as `[(name, dtype, data)]`: `data` is the little-endian bytes of the column for the
/// numeric dtypes (`u8`, `i8`, `f8`, `f4`, `?`: numpy's codes, read with `numpy.frombuffer`),
/// a list of `str` for `str`.
fn table<'py>(py: Python<'py>, t: &Table) -> PyResult<Bound<'py, PyList>> {
    columns(py, t.columns.iter().map(|(n, c)| (*n, c)))
}

/// Columns as [`table`] hands them over.
fn columns<'py, 'c>(
    py: Python<'py>,
    it: impl Iterator<Item = (&'c str, &'c Column)>,
) -> PyResult<Bound<'py, PyList>> {
    let out = PyList::empty(py);
    for (name, column) in it {
        let (dtype, data): (&str, Bound<'py, PyAny>) = match column {
            Column::U64(v) => ("<u8", bytes(py, v.iter().flat_map(|x| x.to_le_bytes()))),
            Column::I64(v) => ("<i8", bytes(py, v.iter().flat_map(|x| x.to_le_bytes()))),
            Column::F64(v) => ("<f8", bytes(py, v.iter().flat_map(|x| x.to_le_bytes()))),
            Column::F32(v) => ("<f4", bytes(py, v.iter().flat_map(|x| x.to_le_bytes()))),
            Column::Bool(v) => ("?", bytes(py, v.iter().map(|&b| u8::from(b)))),
            Column::Str(v) => ("str", PyList::new(py, v)?.into_any()),
        };
        out.append((name, dtype, data))?;
    }
    Ok(out)
}

fn bytes<'py>(py: Python<'py>, it: impl Iterator<Item = u8>) -> Bound<'py, PyAny> {
    let v: Vec<u8> = it.collect();
    PyBytes::new(py, &v).into_any()
}

/// Resolves a configuration as `swarmfl run --preset P --config F --set K=V...` does.
fn resolve(
    preset: Option<&str>,
    config: Option<PathBuf>,
    overrides: &[String],
) -> PyResult<Config> {
    Config::resolve(preset, config.as_deref(), overrides).map_err(err)
}

/// A plug-in attack or rule as the Python side hands it over: (name, what was hashed, its
/// source, the adapter to call).
type AttackArg = plugins::Arg;

/// Runs `work` on its own thread while this one checks for Ctrl-C ten times a second (Python
/// handles signals on the main thread only): Ctrl-C sets the flag `work` is given, which stops
/// it at its next record, and is raised. A plug-in's first error (`failure`) is raised before
/// `work`'s own error (the "stopped" it caused).
fn on_worker<T: Send>(
    py: Python<'_>,
    failure: &plugins::Failure,
    work: impl FnOnce(&AtomicBool) -> anyhow::Result<T> + Send,
) -> PyResult<T> {
    let stop = AtomicBool::new(false);
    let mut interrupted: Option<PyErr> = None;
    let outcome = std::thread::scope(|scope| {
        let stop = &stop;
        let worker = scope.spawn(move || work(stop));
        while !worker.is_finished() {
            py.detach(|| std::thread::sleep(Duration::from_millis(100)));
            if interrupted.is_none() {
                if let Err(e) = py.check_signals() {
                    interrupted = Some(e);
                    stop.store(true, Ordering::SeqCst);
                }
            }
        }
        worker.join()
    });
    if let Some(e) = plugins::take_failure(failure) {
        return Err(e);
    }
    if let Some(e) = interrupted {
        return Err(e);
    }
    outcome
        .map_err(|_| SwarmflError::new_err("the run's thread panicked"))?
        .map_err(err)
}

/// The check a run or fork makes before each record: stop after a plug-in failed or Ctrl-C.
fn check_stop<'a>(
    stop: &'a AtomicBool,
    failure: &'a plugins::Failure,
    out: &'a std::path::Path,
) -> impl FnMut() -> anyhow::Result<()> + 'a {
    move || {
        if plugins::failed(failure) {
            anyhow::bail!("a plug-in failed: {} is truncated", out.display());
        }
        if stop.load(Ordering::Relaxed) {
            anyhow::bail!(
                "interrupted: {} is truncated (no summary); run again to redo it",
                out.join("run.swlog").display()
            );
        }
        Ok(())
    }
}

/// Runs a simulation into `out` (`run.swlog`, `summary.json`) as `swarmfl run` does, and
/// returns the summary's JSON text. Ctrl-C stops it at its next record and raises
/// `KeyboardInterrupt` (the log left in `out` is truncated). `attack` is a plug-in attack
/// (`byzantine.kind = "plugin"`, see `plugins.rs`).
#[pyfunction]
#[pyo3(signature = (preset, config, overrides, seed, out, quiet, attack=None, rule=None))]
#[allow(clippy::too_many_arguments)]
fn run(
    py: Python<'_>,
    preset: Option<String>,
    config: Option<PathBuf>,
    overrides: Vec<String>,
    seed: u64,
    out: PathBuf,
    quiet: bool,
    attack: AttackArg,
    rule: AttackArg,
) -> PyResult<String> {
    let config = resolve(preset.as_deref(), config, &overrides)?;
    let (plugins, failure) = plugins::plugins(attack, rule);
    let outcome = on_worker(py, &failure, |stop| {
        let check = check_stop(stop, &failure, &out);
        RunRequest::new(config, seed, &out)
            .plugins(&plugins)
            .run_checked(&Lines { quiet }, check)
    })?;
    // Through a `Value`, whose keys are sorted as in `summary.json`.
    let summary = serde_json::to_value(&outcome.summary).map_err(err)?;
    serde_json::to_string(&summary).map_err(err)
}

/// Replays the log at `log` (`swarmfl replay [--resimulate]`) offered the plug-in `attack`:
/// refuses a log whose plug-in is not given or whose source changed, naming it. Returns
/// `(records, checkpoints, blocks, final_hash)`.
#[pyfunction]
#[pyo3(signature = (log, resimulate, attack=None, rule=None))]
fn replay(
    py: Python<'_>,
    log: PathBuf,
    resimulate: bool,
    attack: AttackArg,
    rule: AttackArg,
) -> PyResult<(u64, u64, u64, String)> {
    use swarmfl_core::replay as core_replay;
    let (plugins, failure) = plugins::plugins(attack, rule);
    let report = on_worker(py, &failure, |_| {
        let name = log.display().to_string();
        let reader =
            swarmfl_core::log::LogReader::open(&log).map_err(core_replay::ReplayError::from)?;
        core_replay::check_plugins(&reader, &name, &plugins)?;
        drop(reader);
        Ok(if resimulate {
            core_replay::resimulate_with(&log, &plugins)?
        } else {
            core_replay::replay(&log)?
        })
    })?;
    Ok((
        report.records,
        report.checkpoints,
        report.blocks,
        report.final_hash.to_hex(),
    ))
}

/// Forks the log at `log` at block `at` with `overrides` into `out` (`swarmfl fork`), offered
/// the plug-ins `attack` and `rule` (the parent's must be given, with the source its header
/// records).
#[pyfunction]
#[pyo3(signature = (log, at, overrides, out, quiet, attack=None, rule=None))]
#[allow(clippy::too_many_arguments)]
fn fork(
    py: Python<'_>,
    log: PathBuf,
    at: u64,
    overrides: Vec<String>,
    out: PathBuf,
    quiet: bool,
    attack: AttackArg,
    rule: AttackArg,
) -> PyResult<()> {
    let (plugins, failure) = plugins::plugins(attack, rule);
    on_worker(py, &failure, |stop| {
        let check = check_stop(stop, &failure, &out);
        swarmfl_study::fork::fork_with(
            &log,
            at,
            &overrides,
            (&out, Chosen::Explicit),
            &Lines { quiet },
            &plugins,
            check,
        )
        .map(|_| ())
    })
}

/// Runs a sweep (`swarmfl sweep`: a built-in experiment, or the grid of `grid`'s
/// `KEY=V1,V2` axes on `preset`) into `out`. The sweep runs on its own threads; this thread
/// waits, calls `progress(done, total, line, error)` after each task and checks for Ctrl-C
/// (`KeyboardInterrupt`) ten times a second. An exception (from `progress` or Ctrl-C) stops the
/// sweep: no new task starts and the runs under way stop at their next record without a
/// result file (a re-run redoes them), then it is raised. Returns `(selected, ran, skipped, failed: [(point, seed, error)], wall_s)`.
#[pyfunction]
#[pyo3(signature = (experiment, preset, grid, overrides, runs, jobs, shard, out, keep_logs, progress))]
#[allow(clippy::too_many_arguments)]
fn sweep(
    py: Python<'_>,
    experiment: Option<String>,
    preset: Option<String>,
    grid: Vec<String>,
    overrides: Vec<String>,
    runs: Option<u32>,
    jobs: Option<usize>,
    shard: Option<String>,
    out: PathBuf,
    keep_logs: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<SweepResult> {
    let shard = match shard {
        Some(text) => Shard::parse(&text).map_err(err)?,
        None => Shard::ALL,
    };
    let opts = SweepOptions {
        experiment,
        preset,
        grid,
        out,
        runs,
        jobs,
        shard,
        overrides,
        keep_logs,
    };
    let stop = AtomicBool::new(false);
    let mut raised: Option<PyErr> = None;
    let (tx, rx) = mpsc::channel::<TaskDone>();
    // In a mutex so that the wait can run with the interpreter released (a receiver is not
    // Sync); only this thread locks it.
    let rx = Mutex::new(rx);
    let outcome = std::thread::scope(|scope| {
        let stop = &stop;
        let opts = &opts;
        let worker = scope.spawn(move || {
            let hook = move |t: &TaskDone| {
                // The receiver lives until this thread ends: a failed send cannot happen.
                let _ = tx.send(t.clone());
                !stop.load(Ordering::SeqCst)
            };
            swarmfl_study::sweep::sweep(opts, &Quiet, Some(&hook))
        });
        loop {
            let next = py.detach(|| {
                rx.lock()
                    .expect("only this thread locks it")
                    .recv_timeout(Duration::from_millis(100))
            });
            match next {
                Ok(t) => {
                    if let (Some(cb), None) = (&progress, &raised) {
                        if let Err(e) = cb.call1(py, (t.done, t.total, t.line, t.error)) {
                            raised = Some(e);
                            stop.store(true, Ordering::SeqCst);
                        }
                    }
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => break,
            }
            if raised.is_none() {
                if let Err(e) = py.check_signals() {
                    raised = Some(e);
                    stop.store(true, Ordering::SeqCst);
                }
            }
        }
        py.detach(|| worker.join())
    });
    let outcome = match outcome {
        Ok(result) => result.map_err(err)?,
        Err(_) => return Err(SwarmflError::new_err("the sweep's thread panicked")),
    };
    if let Some(e) = raised {
        return Err(e);
    }
    let failed = outcome
        .failed
        .iter()
        .map(|(t, e)| (t.point.clone(), t.seed, e.clone()))
        .collect();
    Ok((
        outcome.selected,
        outcome.ran,
        outcome.skipped,
        failed,
        outcome.wall_s,
    ))
}

/// What [`sweep`] returns: tasks selected, ran, skipped, the failures and the wall time.
type SweepResult = (usize, usize, usize, Vec<(String, u64, String)>, f64);

/// The results under a sweep's directory as one table (`report::results_frame`): a row per
/// result file, every override a column.
#[pyfunction]
fn results<'py>(py: Python<'py>, dir: PathBuf) -> PyResult<Bound<'py, PyList>> {
    let frame = py
        .detach(|| swarmfl_study::report::results_frame(&dir))
        .map_err(err)?;
    columns(py, frame.iter().map(|(n, c)| (n.as_str(), c)))
}

/// Writes the report of a results directory (`swarmfl report DIR --out OUT`); returns the
/// path of its report.md.
#[pyfunction]
fn report(py: Python<'_>, dir: PathBuf, out: PathBuf) -> PyResult<PathBuf> {
    py.detach(|| swarmfl_study::report::report(&dir, &out))
        .map_err(err)
}

/// The resolved configuration's TOML text (what a run's header records).
#[pyfunction]
#[pyo3(signature = (preset, config, overrides))]
fn config_toml(
    preset: Option<String>,
    config: Option<PathBuf>,
    overrides: Vec<String>,
) -> PyResult<String> {
    Ok(resolve(preset.as_deref(), config, &overrides)?.to_toml())
}

/// Writes the CSV tables of a log into a directory, as `swarmfl export` does.
#[pyfunction]
fn export(py: Python<'_>, log: PathBuf, out: PathBuf) -> PyResult<()> {
    let line = py
        .detach(|| swarmfl_study::export::export(&log, &out, &Lines { quiet: false }))
        .map_err(err)?;
    println!("{line}");
    Ok(())
}

/// Writes the viewer of a log (one HTML file), as `swarmfl view` does; returns `(frames,
/// sealings, height, bytes)`.
#[pyfunction]
fn view(py: Python<'_>, log: PathBuf, out: PathBuf) -> PyResult<(usize, u64, u64, usize)> {
    let v = py
        .detach(|| swarmfl_study::view::view(&log, &out, &Lines { quiet: false }))
        .map_err(err)?;
    Ok((v.frames, v.sealings, v.height, v.bytes))
}

/// Draws the world of a log at `time_s` or right after `block` (exactly one) into `out` (SVG
/// or PNG), as `swarmfl snapshot` does; returns the picture's title.
#[pyfunction]
#[pyo3(signature = (log, out, time_s=None, block=None))]
fn snapshot(
    py: Python<'_>,
    log: PathBuf,
    out: PathBuf,
    time_s: Option<f64>,
    block: Option<u64>,
) -> PyResult<String> {
    py.detach(|| {
        swarmfl_study::snapshot::snapshot(&log, time_s, block, &out, &Lines { quiet: false })
    })
    .map_err(err)
}

/// Every robot's pose every `every_s` simulated seconds (`inspect::poses_table`).
#[pyfunction]
fn poses<'py>(py: Python<'py>, log: PathBuf, every_s: f64) -> PyResult<Bound<'py, PyList>> {
    let t = py
        .detach(|| inspect::poses_table(&log, every_s))
        .map_err(err)?;
    table(py, &t)
}

/// The seekers of the last logs [`at_block`] looked into (at most [`MAX_SEEKERS`]): each keeps
/// a full-state snapshot every `output.snapshot_every_blocks` blocks it folds past, so walking
/// a run's blocks (`Run.at(block=...)` in a loop) folds its log about once, not once per block.
static SEEKERS: std::sync::Mutex<Vec<(PathBuf, inspect::Seeker)>> =
    std::sync::Mutex::new(Vec::new());

/// Most logs whose seekers [`SEEKERS`] keeps (the oldest is dropped first).
const MAX_SEEKERS: usize = 2;

/// The state right after block `block` of a chain run's final canonical chain, as the JSON
/// text of `swarmfl inspect --block B --json`.
#[pyfunction]
fn at_block(py: Python<'_>, log: PathBuf, block: u64) -> PyResult<String> {
    let report = py
        .detach(|| {
            let mut seekers = SEEKERS.lock().unwrap_or_else(|p| p.into_inner());
            let at = match seekers.iter().position(|(path, _)| *path == log) {
                Some(at) => at,
                None => {
                    let seeker = inspect::Seeker::open(&log)?;
                    if seekers.len() == MAX_SEEKERS {
                        seekers.remove(0);
                    }
                    seekers.push((log.clone(), seeker));
                    seekers.len() - 1
                }
            };
            seekers[at].1.block_report(block, None)
        })
        .map_err(err)?;
    serde_json::to_string(&report).map_err(err)
}

/// The state of a baseline run at the last checkpoint at or before `time_s`, as JSON text.
#[pyfunction]
fn at_time(py: Python<'_>, log: PathBuf, time_s: f64) -> PyResult<String> {
    if !(time_s.is_finite() && time_s >= 0.0) {
        return Err(SwarmflError::new_err(format!(
            "{}: the time must be a non-negative number of seconds, got {time_s}",
            log.display()
        )));
    }
    let at = SimTime((time_s * 1000.0).round() as u64);
    let report = py.detach(|| timeline::report_at(&log, at)).map_err(err)?;
    serde_json::to_string(&report).map_err(err)
}

/// `swarmfl blame LOG --json`: each robot's influence on `outcome` read at the end, at block
/// `block` or where `until` first holds, as JSON text.
#[pyfunction]
#[pyo3(signature = (log, outcome, until=None, block=None, robots=None, as_honest=true, quiet=true))]
#[allow(clippy::too_many_arguments)]
fn blame(
    py: Python<'_>,
    log: PathBuf,
    outcome: String,
    until: Option<String>,
    block: Option<u64>,
    robots: Option<Vec<u32>>,
    as_honest: bool,
    quiet: bool,
) -> PyResult<String> {
    use swarmfl_study::blame::{At, BlameRequest};
    let request = BlameRequest {
        outcome,
        at: At::from_flags(until, block),
        robots,
        as_honest,
    };
    let report = py
        .detach(|| swarmfl_study::blame::blame(&log, &request, &Lines { quiet }))
        .map_err(err)?;
    serde_json::to_string(&report).map_err(err)
}

/// `swarmfl contributions LOG --json`: leave-one-out and Shapley values, as JSON text.
#[pyfunction]
#[pyo3(signature = (log, outcome, until=None, block=None, samples=0, seed=1, quiet=true))]
#[allow(clippy::too_many_arguments)]
fn contributions(
    py: Python<'_>,
    log: PathBuf,
    outcome: String,
    until: Option<String>,
    block: Option<u64>,
    samples: u32,
    seed: u64,
    quiet: bool,
) -> PyResult<String> {
    let at = swarmfl_study::blame::At::from_flags(until, block);
    let c = py
        .detach(|| {
            swarmfl_study::blame::contributions(
                &log,
                &outcome,
                &at,
                samples,
                seed,
                &Lines { quiet },
            )
        })
        .map_err(err)?;
    serde_json::to_string(&c).map_err(err)
}

/// The first checkpoint of a baseline run where `expr` holds: `(time_s, leaves)` or None.
#[pyfunction]
fn bisect_by_time(
    py: Python<'_>,
    log: PathBuf,
    expr: String,
    monotone: bool,
) -> PyResult<Option<(f64, Leaves)>> {
    let predicate = Expr::parse(&expr).map_err(err)?;
    let (hit, _) = py
        .detach(|| timeline::bisect_by_time(&log, &predicate, monotone))
        .map_err(err)?;
    Ok(hit)
}

/// The leaf values of a predicate where it holds: `(name, value)`.
type Leaves = Vec<(String, f64)>;

/// One fold of a log (`inspect::index_run`): its tables and its per-block values.
#[pyclass(unsendable, module = "swarmfl._swarmfl")]
struct Index {
    index: RunIndex,
}

#[pymethods]
impl Index {
    /// Folds the log at `path` (checking every checkpoint).
    /// A log made with a plug-in rule needs it (`rule`): every fold re-executes the contract.
    #[new]
    #[pyo3(signature = (path, rule=None))]
    fn new(py: Python<'_>, path: PathBuf, rule: AttackArg) -> PyResult<Self> {
        let (plugins, failure) = plugins::plugins(None, rule);
        let index = py.detach(|| {
            // A changed rule is refused by name here, before the fold diverges at genesis.
            let reader = swarmfl_core::log::LogReader::open(&path)?;
            let rules: Vec<_> = reader
                .header()
                .plugins
                .iter()
                .filter(|p| p.kind == "rule")
                .cloned()
                .collect();
            plugins.check(&rules).map_err(anyhow::Error::msg)?;
            drop(reader);
            inspect::index_run(&path, None).map_err(anyhow::Error::from)
        });
        if let Some(e) = plugins::take_failure(&failure) {
            return Err(e);
        }
        Ok(Index {
            index: index.map_err(err)?,
        })
    }

    /// `chain`, `gossip` or `central`.
    #[getter]
    fn aggregation(&self) -> &'static str {
        self.index.config.learn.aggregation.name()
    }

    /// The run's seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.index.seed
    }

    /// Records in the log.
    #[getter]
    fn records(&self) -> u64 {
        self.index.records
    }

    /// The last height of the final canonical chain (0 for a baseline run).
    #[getter]
    fn last_height(&self) -> u64 {
        self.index.last_height()
    }

    /// Why the log is truncated (its intact prefix was read), or None.
    #[getter]
    fn truncated(&self) -> Option<String> {
        self.index.truncated.clone()
    }

    /// Which robots are Byzantine, in robot order.
    #[getter]
    fn byzantine(&self) -> Vec<bool> {
        self.index.byzantine.clone()
    }

    /// The run's resolved configuration as TOML.
    #[getter]
    fn config_toml(&self) -> String {
        self.index.config.to_toml()
    }

    /// The rounds table (`RunIndex::rounds_table`).
    fn rounds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        table(py, &self.index.rounds_table().map_err(err)?)
    }

    /// The submissions table (`RunIndex::submissions_table`).
    fn submissions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        table(py, &self.index.submissions_table().map_err(err)?)
    }

    /// The balances table (`RunIndex::balances_table`).
    fn balances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        table(py, &self.index.balances_table().map_err(err)?)
    }

    /// Every model submission on the final canonical chain with its outcome, refused ones
    /// included (`RunIndex::outcomes_table`).
    fn outcomes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        table(py, &self.index.outcomes_table().map_err(err)?)
    }

    /// The chain sizes table (`RunIndex::chain_bytes_table`).
    fn chain_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        table(py, &self.index.chain_bytes_table().map_err(err)?)
    }

    /// The final data sets (`RunIndex::trajectories_table`).
    fn trajectories<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        table(py, &self.index.trajectories_table())
    }

    /// The first block of a chain run where `expr` holds, as `swarmfl bisect`: `(height,
    /// time_s, leaves)` or None.
    fn bisect(&self, expr: &str, monotone: bool) -> PyResult<Option<(u64, f64, Leaves)>> {
        if self.index.config.learn.aggregation != Aggregation::Chain {
            return Err(SwarmflError::new_err(format!(
                "{}: a {} run has no blocks: bisect it by time",
                self.index.path,
                self.aggregation()
            )));
        }
        let predicate = Expr::parse(expr).map_err(err)?;
        let values = self.index.values();
        let hit = inspect::bisect(&values, &predicate, monotone).map_err(err)?;
        Ok(hit.map(|h| (h.height, h.time_s, h.values)))
    }
}

/// The module `swarmfl._swarmfl`.
#[pymodule]
fn _swarmfl(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SwarmflError", m.py().get_type::<SwarmflError>())?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(replay, m)?)?;
    m.add_function(wrap_pyfunction!(fork, m)?)?;
    m.add_function(wrap_pyfunction!(config_toml, m)?)?;
    m.add_function(wrap_pyfunction!(export, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(results, m)?)?;
    m.add_function(wrap_pyfunction!(report, m)?)?;
    m.add_function(wrap_pyfunction!(poses, m)?)?;
    m.add_function(wrap_pyfunction!(view, m)?)?;
    m.add_function(wrap_pyfunction!(snapshot, m)?)?;
    m.add_function(wrap_pyfunction!(at_block, m)?)?;
    m.add_function(wrap_pyfunction!(at_time, m)?)?;
    m.add_function(wrap_pyfunction!(bisect_by_time, m)?)?;
    m.add_function(wrap_pyfunction!(blame, m)?)?;
    m.add_function(wrap_pyfunction!(contributions, m)?)?;
    m.add_class::<Index>()?;
    Ok(())
}

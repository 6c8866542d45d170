//! `swarmfl sweep`: the paper's experiments (docs/SPEC.md section 7) as a fixed task list of
//! (configuration point, seed) pairs, run locally in parallel or one shard at a time under a
//! cluster scheduler.
//!
//! The task list is [`experiments::tasks`]: point-major, task `i = p * R + (seed - 1)`. A shard
//! `I/N` runs the tasks with `i % N == I`, so shards `0/N .. (N-1)/N` cover every task exactly
//! once whatever `N` is. Each task writes one result file (see [`crate::results`]); a task
//! whose result file exists and parses is skipped, so a re-run resumes an interrupted sweep and
//! a retried task simply overwrites.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::Context;
use swarmfl_core::config::Config;

use crate::experiments::{self, Experiment, Task};
use crate::grid;
use crate::progress::Watch;
use crate::results::{
    extra_overrides, is_done, result_path, show_overrides, write_atomic, TMP_DIR,
};
use crate::run;
use crate::summary::{ResultFile, SweepTask};

/// A share of the task list: the tasks whose index is `index` modulo `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: u32,
    /// The number of shards.
    pub count: u32,
}

impl Shard {
    /// The whole task list.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `I/N` (`0 <= I < N`).
    pub fn parse(text: &str) -> anyhow::Result<Shard> {
        let (i, n) = text
            .split_once('/')
            .with_context(|| format!("--shard {text:?}: expected I/N, e.g. --shard 0/3"))?;
        let index: u32 = i
            .trim()
            .parse()
            .with_context(|| format!("--shard {text:?}: I must be a non-negative integer"))?;
        let count: u32 = n
            .trim()
            .parse()
            .with_context(|| format!("--shard {text:?}: N must be a positive integer"))?;
        Shard::new(index, count)
    }

    /// A checked shard.
    pub fn new(index: u32, count: u32) -> anyhow::Result<Shard> {
        anyhow::ensure!(count >= 1, "shard count must be at least 1, got {count}");
        anyhow::ensure!(
            index < count,
            "shard index {index} is out of range: it must be below the shard count {count}"
        );
        Ok(Shard { index, count })
    }

    /// The shard to run: `--shard I/N` if given; otherwise from the scheduler's environment
    /// (`get` reads a variable): a Slurm job array (`SLURM_ARRAY_TASK_ID` minus
    /// `SLURM_ARRAY_TASK_MIN` (0 if unset) out of `SLURM_ARRAY_TASK_COUNT`), or a Kubernetes
    /// indexed Job (`JOB_COMPLETION_INDEX` out of `--shards N` or `SWARMFL_SHARDS`); otherwise
    /// every task.
    pub fn resolve(
        flag: Option<&str>,
        shards: Option<u32>,
        get: impl Fn(&str) -> Option<String>,
    ) -> anyhow::Result<Shard> {
        if let Some(text) = flag {
            return Shard::parse(text);
        }
        let number = |name: &str| -> anyhow::Result<Option<u32>> {
            get(name)
                .filter(|v| !v.trim().is_empty())
                .map(|v| {
                    v.trim().parse::<u32>().with_context(|| {
                        format!("environment variable {name}={v:?} is not a non-negative integer")
                    })
                })
                .transpose()
        };
        if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
            let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let count = match shards {
                Some(n) => n,
                None => number("SLURM_ARRAY_TASK_COUNT")?.context(
                    "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not; pass --shards N",
                )?,
            };
            let index = id.checked_sub(min).with_context(|| {
                format!("SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}")
            })?;
            return Shard::new(index, count);
        }
        if let Some(index) = number("JOB_COMPLETION_INDEX")? {
            let count = match shards {
                Some(n) => n,
                None => number("SWARMFL_SHARDS")?.context(
                    "JOB_COMPLETION_INDEX is set but the shard count is not: pass --shards N or \
                     set SWARMFL_SHARDS to the Job's completions",
                )?,
            };
            return Shard::new(index, count);
        }
        match shards {
            Some(n) if n != 1 => anyhow::bail!(
                "--shards {n} needs a shard index: --shard I/{n}, SLURM_ARRAY_TASK_ID or \
                 JOB_COMPLETION_INDEX"
            ),
            _ => Ok(Shard::ALL),
        }
    }

    /// Whether task `index` belongs to this shard.
    pub fn owns(self, index: usize) -> bool {
        index % self.count as usize == self.index as usize
    }
}

/// Refuses to add results to a point directory that holds results of another configuration
/// (other `--set` values, or the same ones under presets of another version), naming the file
/// and both settings: averaging them would silently mix two studies.
fn check_settings(
    point_dir: &Path,
    config_hash: &str,
    overrides: &[String],
    point_overrides: &[String],
) -> anyhow::Result<()> {
    let Ok(entries) = std::fs::read_dir(point_dir) else {
        return Ok(());
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("seed") && n.ends_with(".json"))
        })
        .collect();
    files.sort();
    for file in files {
        let Ok(made) = ResultFile::read(&file) else {
            // An unreadable result is re-run (and overwritten) like a missing one.
            continue;
        };
        let theirs = made.summary.run.config_hash.as_str();
        if theirs == config_hash {
            continue;
        }
        let their_overrides = extra_overrides(&made.sweep, point_overrides);
        let why = if their_overrides == overrides {
            format!(
                "the same {} under another version's presets (configuration {} vs {})",
                show_overrides(overrides),
                &theirs[..theirs.len().min(12)],
                &config_hash[..12]
            )
        } else {
            format!(
                "{}, this sweep uses {}",
                show_overrides(&their_overrides),
                show_overrides(overrides)
            )
        };
        anyhow::bail!(
            "{} holds results of other settings: {} was made with {why}. A report would \
             average the two; sweep into another --out directory (or repeat the same --set to \
             add seeds)",
            point_dir.display(),
            file.display(),
        );
    }
    Ok(())
}

/// What `swarmfl sweep` was asked to do.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// A built-in experiment's id (or None with `grid`).
    pub experiment: Option<String>,
    /// The preset of a grid (default `paper`); a built-in experiment has its own.
    pub preset: Option<String>,
    /// The grid's axes, each `KEY=V1,V2,...` (see [`crate::grid`]); empty for an experiment.
    pub grid: Vec<String>,
    /// The results directory.
    pub out: PathBuf,
    /// Runs per point (default: the paper's).
    pub runs: Option<u32>,
    /// Parallel runs (default: the number of cores).
    pub jobs: Option<usize>,
    /// The share of the task list to run.
    pub shard: Shard,
    /// Extra overrides for every task.
    pub overrides: Vec<String>,
    /// Keep each run's full log in `DIR/<experiment>/<point>/seed<N>/`.
    pub keep_logs: bool,
}

/// What a sweep did.
#[derive(Debug, Default)]
pub struct SweepOutcome {
    /// Tasks in this shard.
    pub selected: usize,
    /// Tasks skipped because their result file was already there.
    pub skipped: usize,
    /// Tasks run now.
    pub ran: usize,
    /// Failed tasks with their error.
    pub failed: Vec<(Task, String)>,
    /// Wall-clock seconds of the whole sweep.
    pub wall_s: f64,
    /// Whether the progress hook stopped the sweep before every task ran.
    pub stopped: bool,
}

/// The experiment a sweep runs: the built-in one named, or the grid of `--grid` on its preset.
pub fn plan(opts: &SweepOptions) -> anyhow::Result<Experiment> {
    match (&opts.experiment, opts.grid.is_empty()) {
        (Some(name), true) => {
            if let Some(p) = &opts.preset {
                anyhow::bail!(
                    "--preset {p}: the experiment {name} has its own preset ({name}); --preset \
                     is for a --grid sweep"
                );
            }
            experiments::experiment(name)
        }
        (Some(name), false) => anyhow::bail!(
            "give either an experiment ({name}) or --grid axes, not both: a grid runs on \
             --preset P (default paper)"
        ),
        (None, true) => anyhow::bail!(
            "nothing to sweep: name an experiment ({}) or give --grid KEY=V1,V2 (e.g. \
             --grid contract.rule=median,krum)",
            experiments::EXPERIMENTS.join(", ")
        ),
        (None, false) => {
            let axes = opts
                .grid
                .iter()
                .map(|g| grid::parse_axis(g))
                .collect::<anyhow::Result<Vec<_>>>()?;
            grid::experiment(
                opts.preset.as_deref().unwrap_or("paper"),
                &axes,
                &opts.overrides,
            )
        }
    }
}

/// One finished task, as a sweep's progress hook sees it.
#[derive(Clone, Debug)]
pub struct TaskDone {
    /// Tasks finished so far in this sweep (this one included).
    pub done: usize,
    /// Tasks this sweep runs (its shard's, minus those already done).
    pub total: usize,
    /// The progress line (`[3/8] grid-smoke <point> seed 2 done in 4.1 s`).
    pub line: String,
    /// The task's error, if it failed.
    pub error: Option<String>,
}

/// A sweep's progress hook: called after each task from the worker that ran it; returning
/// false stops the sweep: no new task starts and the runs under way are interrupted at their
/// next record, leaving no result file (a re-run redoes them).
pub type Hook<'a> = &'a (dyn Fn(&TaskDone) -> bool + Sync);

/// Runs a sweep (or one shard of it), showing its progress on `watch`; a `hook` gets every
/// finished task (and stops the sweep by returning false).
pub fn sweep(
    opts: &SweepOptions,
    watch: &dyn Watch,
    hook: Option<Hook<'_>>,
) -> anyhow::Result<SweepOutcome> {
    let exp = plan(opts)?;
    let runs = opts.runs.unwrap_or(exp.runs);
    anyhow::ensure!(runs >= 1, "--runs must be at least 1");
    let all = experiments::tasks(&exp, runs, &opts.overrides);
    // Resolve every point's configuration up front: a bad --set or grid value fails before
    // any run.
    let mut configs = Vec::with_capacity(exp.points.len());
    for point in &exp.points {
        let mut overrides = point.overrides.clone();
        overrides.extend(opts.overrides.iter().cloned());
        let config = Config::resolve(Some(&exp.preset), None, &overrides)
            .with_context(|| format!("{} point {}", exp.name, point.name))?;
        configs.push(config);
    }
    for (point, config) in exp.points.iter().zip(&configs) {
        check_settings(
            &opts.out.join(&exp.name).join(&point.name),
            &config.hash().to_hex(),
            &opts.overrides,
            &point.overrides,
        )?;
    }
    let selected: Vec<Task> = all
        .into_iter()
        .filter(|t| opts.shard.owns(t.index))
        .collect();
    let started = Instant::now();
    let mut outcome = SweepOutcome {
        selected: selected.len(),
        ..SweepOutcome::default()
    };
    let todo: Vec<Task> = selected
        .into_iter()
        .filter(|t| !is_done(&result_path(&opts.out, &t.experiment, &t.point, t.seed)))
        .collect();
    outcome.skipped = outcome.selected - todo.len();
    let jobs = opts
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .clamp(1, todo.len().max(1));
    // Runs side by side already fill the cores; a training's helper thread would only compete
    // with the other runs' world and ledger work (speed only: the bits are the same).
    swarmfl_core::learn::allow_two_thread_training(jobs == 1);
    watch.say(&format!(
        "sweep {}: {} tasks in shard {}/{} ({} already done), {} runs per point, {} parallel",
        exp.name, outcome.selected, opts.shard.index, opts.shard.count, outcome.skipped, runs, jobs
    ));
    let (mut failed, finished) = run_parallel(opts, &exp, &todo, &configs, jobs, watch, hook);
    failed.sort_by_key(|(t, _)| t.index);
    outcome.ran = finished - failed.len();
    outcome.stopped = finished < todo.len();
    outcome.failed = failed;
    outcome.wall_s = started.elapsed().as_secs_f64();
    Ok(outcome)
}

/// Runs `todo` on `jobs` threads (each takes the next task), with a progress line (or the
/// hook's); returns the failed tasks with their error, in completion order, and how many
/// tasks finished.
fn run_parallel(
    opts: &SweepOptions,
    exp: &Experiment,
    todo: &[Task],
    configs: &[Config],
    jobs: usize,
    watch: &dyn Watch,
    hook: Option<Hook<'_>>,
) -> (Vec<(Task, String)>, usize) {
    let progress =
        Mutex::new(watch.start(&format!("sweep {}", exp.name), "tasks", todo.len() as u64));
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let failed = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                if stop.load(Ordering::SeqCst) {
                    break;
                }
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(task) = todo.get(k) else { break };
                let task_started = Instant::now();
                let result = run_task(opts, exp, task, configs[task.point_index].clone(), &stop);
                if result.is_err() && stop.load(Ordering::SeqCst) {
                    // Interrupted by a stop: not a failure, and not done (a re-run redoes it).
                    break;
                }
                let finished = done.fetch_add(1, Ordering::SeqCst) + 1;
                let line = match &result {
                    Ok(()) => format!(
                        "[{finished}/{}] {} {} seed {} done in {:.1} s",
                        todo.len(),
                        task.experiment,
                        task.point,
                        task.seed,
                        task_started.elapsed().as_secs_f64()
                    ),
                    Err(e) => format!(
                        "[{finished}/{}] {} {} seed {} FAILED: {e:#}",
                        todo.len(),
                        task.experiment,
                        task.point,
                        task.seed
                    ),
                };
                if let Some(hook) = hook {
                    let report = TaskDone {
                        done: finished,
                        total: todo.len(),
                        line: line.clone(),
                        error: result.as_ref().err().map(|e| format!("{e:#}")),
                    };
                    if !hook(&report) {
                        stop.store(true, Ordering::SeqCst);
                    }
                }
                let mut progress = progress.lock().expect("no worker panics holding it");
                if result.is_err() {
                    progress.say(&line);
                }
                progress.set(finished as u64, &|| line.clone());
                if let Err(e) = result {
                    failed
                        .lock()
                        .expect("no worker panics while holding the lock")
                        .push((task.clone(), format!("{e:#}")));
                }
            });
        }
    });
    let finished = done.into_inner();
    progress
        .into_inner()
        .expect("workers finished")
        .finish(finished as u64);
    (failed.into_inner().expect("workers finished"), finished)
}

/// Runs one task and writes its result file.
fn run_task(
    opts: &SweepOptions,
    exp: &Experiment,
    task: &Task,
    config: Config,
    stop: &AtomicBool,
) -> anyhow::Result<()> {
    let result = result_path(&opts.out, &task.experiment, &task.point, task.seed);
    let run_dir = if opts.keep_logs {
        result.with_extension("")
    } else {
        opts.out.join(TMP_DIR).join(format!(
            "{}-{}-seed{}-{}",
            task.experiment,
            task.point,
            task.seed,
            std::process::id()
        ))
    };
    let point = &exp.points[task.point_index];
    let outcome = run::RunRequest::new(config, task.seed, &run_dir)
        .stop(stop)
        .run(&crate::progress::Quiet);
    if !opts.keep_logs {
        // Best effort: a leftover temporary directory does not change any result.
        let _ = std::fs::remove_dir_all(&run_dir);
    }
    let made = ResultFile {
        summary: outcome?.summary,
        sweep: SweepTask {
            experiment: task.experiment.clone(),
            point: task.point.clone(),
            seed: task.seed,
            task: task.index,
            overrides: task.overrides.clone(),
            preset: exp.preset.clone(),
            point_index: task.point_index,
            // serde_json writes a non-finite x as null, as it did.
            x: Some(point.x).filter(|x| x.is_finite()),
        },
    };
    write_atomic(&result, &made)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::{experiment, tasks, EXPERIMENTS};
    use swarmfl_core::inspect::Column;

    fn env(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let vars: Vec<(String, String)> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |name: &str| vars.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone())
    }

    #[test]
    fn shards_cover_every_task_exactly_once() {
        let axes = [
            grid::parse_axis("contract.rule=median,krum,geomed").unwrap(),
            grid::parse_axis("byzantine.count=1,3").unwrap(),
        ];
        let grid = grid::experiment("smoke", &axes, &[]).unwrap();
        let experiments = EXPERIMENTS.map(|name| experiment(name).unwrap());
        for exp in experiments.iter().chain([&grid]) {
            let name = &exp.name;
            for runs in [1u32, 3, exp.runs] {
                let list = tasks(exp, runs, &["run.duration_s=600".to_string()]);
                for count in 1..=7u32 {
                    let mut seen = vec![0u32; list.len()];
                    for index in 0..count {
                        let shard = Shard::new(index, count).unwrap();
                        for t in list.iter().filter(|t| shard.owns(t.index)) {
                            seen[t.index] += 1;
                        }
                    }
                    assert!(seen.iter().all(|&n| n == 1), "{name} runs {runs} N {count}");
                }
            }
        }
    }

    #[test]
    fn shards_come_from_the_flag_or_the_scheduler() {
        let check = |flag: Option<&str>,
                     shards: Option<u32>,
                     vars: &[(&str, &str)],
                     expect: Option<(u32, u32)>| {
            let got = Shard::resolve(flag, shards, env(vars)).ok();
            assert_eq!(
                got.map(|s| (s.index, s.count)),
                expect,
                "{flag:?} {shards:?} {vars:?}"
            );
        };
        check(None, None, &[], Some((0, 1)));
        check(Some("1/3"), None, &[], Some((1, 3)));
        check(Some("3/3"), None, &[], None);
        check(Some("0/0"), None, &[], None);
        check(Some("x"), None, &[], None);
        check(
            Some("2/3"),
            None,
            &[
                ("SLURM_ARRAY_TASK_ID", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "3"),
            ],
            Some((2, 3)),
        );
        check(
            None,
            None,
            &[
                ("SLURM_ARRAY_TASK_ID", "2"),
                ("SLURM_ARRAY_TASK_COUNT", "3"),
            ],
            Some((2, 3)),
        );
        check(
            None,
            None,
            &[
                ("SLURM_ARRAY_TASK_ID", "3"),
                ("SLURM_ARRAY_TASK_MIN", "1"),
                ("SLURM_ARRAY_TASK_COUNT", "3"),
            ],
            Some((2, 3)),
        );
        check(None, None, &[("SLURM_ARRAY_TASK_ID", "2")], None);
        check(None, None, &[("JOB_COMPLETION_INDEX", "4")], None);
        check(
            None,
            Some(5),
            &[("JOB_COMPLETION_INDEX", "4")],
            Some((4, 5)),
        );
        check(
            None,
            None,
            &[("JOB_COMPLETION_INDEX", "1"), ("SWARMFL_SHARDS", "2")],
            Some((1, 2)),
        );
        check(None, Some(2), &[], None);
    }

    fn grid_options(out: &Path, grid: &[&str]) -> SweepOptions {
        SweepOptions {
            experiment: None,
            preset: Some("smoke".into()),
            grid: grid.iter().map(|g| g.to_string()).collect(),
            out: out.to_path_buf(),
            runs: Some(1),
            jobs: Some(1),
            shard: Shard::ALL,
            overrides: vec!["run.duration_s=40".into(), "world.robots=6".into()],
            keep_logs: false,
        }
    }

    /// A grid over two keys: every combination runs once, a re-run skips them all, a hook can
    /// stop it, and the report and the results table carry every override and the
    /// duration.
    #[test]
    fn a_grid_sweep_runs_every_combination_resumes_and_reports_its_settings() {
        let dir = std::env::temp_dir().join(format!("swarmfl-grid-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let opts = grid_options(&dir, &["contract.rule=median,krum", "byzantine.count=0,1"]);
        let mut opts = opts;
        // count 0 needs kind none and count 1 a kind: the grid's kind follows the preset's.
        opts.overrides.push("byzantine.kind=faulty".into());
        let err = sweep(&opts, &crate::progress::Quiet, None).unwrap_err();
        let text = format!("{err:#}");
        assert!(
            text.contains("grid-smoke point contract.rule=median+byzantine.count=0"),
            "{text}"
        );
        assert!(!dir.exists(), "nothing ran before the refusal");
        opts.overrides.pop();
        opts.grid[1] = "byzantine.count=1,2".into();
        // Six robots make quorum 3, where krum tolerates no assumed Byzantine robot.
        opts.overrides.push("byzantine.kind=faulty".into());
        opts.overrides.push("contract.assumed_f=0".into());
        let seen = Mutex::new(Vec::new());
        let hook = |t: &TaskDone| {
            seen.lock().unwrap().push((t.done, t.total));
            true
        };
        let first = sweep(&opts, &crate::progress::Quiet, Some(&hook)).unwrap();
        assert_eq!((first.ran, first.skipped, first.failed.len()), (4, 0, 0));
        assert_eq!(*seen.lock().unwrap(), [(1, 4), (2, 4), (3, 4), (4, 4)]);
        for point in [
            "contract.rule=median+byzantine.count=1",
            "contract.rule=krum+byzantine.count=2",
        ] {
            let file = result_path(&dir, "grid-smoke", point, 1);
            let made = ResultFile::read(&file).unwrap();
            assert_eq!(made.sweep.preset, "smoke", "{point}");
        }
        let again = sweep(&opts, &crate::progress::Quiet, None).unwrap();
        assert_eq!((again.ran, again.skipped), (0, 4));
        // A hook that says stop: the running task finishes, no other starts.
        let more = SweepOptions {
            runs: Some(2),
            ..opts.clone()
        };
        let stopped = sweep(&more, &crate::progress::Quiet, Some(&|_: &TaskDone| false)).unwrap();
        assert!(stopped.stopped && stopped.ran == 1, "{stopped:?}");

        let report = dir.join("report");
        crate::report::report(&dir, &report).unwrap();
        let numbers = std::fs::read_to_string(report.join("numbers.csv")).unwrap();
        assert!(numbers.starts_with("experiment,point,x,n,metric,mean,ci95,duration_s,overrides\n"));
        assert!(
            numbers.lines().any(|l| l.starts_with(
                "grid-smoke,contract.rule=krum+byzantine.count=2,1,1,rounds,"
            ) && l.ends_with(
                ",40,contract.rule=krum byzantine.count=2 run.duration_s=40 world.robots=6 byzantine.kind=faulty contract.assumed_f=0"
            )),
            "{numbers}"
        );
        let md = std::fs::read_to_string(report.join("report.md")).unwrap();
        assert!(md.contains("Settings: preset `smoke`"), "{md}");
        assert!(
            md.contains("| contract.rule=median+byzantine.count=1 | 40 | `contract.rule=median byzantine.count=1 run.duration_s=40"),
            "{md}"
        );
        let frame = crate::report::results_frame(&dir).unwrap();
        let column = |name: &str| &frame.iter().find(|(n, _)| n == name).unwrap().1;
        assert_eq!(
            column("contract.rule"),
            &Column::Str(
                ["median", "median", "median", "krum", "krum"]
                    .map(String::from)
                    .to_vec()
            )
        );
        assert_eq!(column("byzantine.count"), &Column::I64(vec![1, 1, 2, 1, 2]));
        assert_eq!(column("seed"), &Column::U64(vec![1, 2, 1, 1, 1]));
        assert_eq!(column("duration_s"), &Column::F64(vec![40.0; 5]));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_grids_are_refused_before_anything_runs_naming_the_key() {
        let dir = std::env::temp_dir().join(format!("swarmfl-badgrid-{}", std::process::id()));
        let e = |grid: &[&str]| {
            format!(
                "{:#}",
                sweep(&grid_options(&dir, grid), &crate::progress::Quiet, None).unwrap_err()
            )
        };
        let text = e(&["contract.rulez=median,krum"]);
        assert!(text.contains("contract.rulez"), "{text}");
        let text = e(&["contract.rule=median,nosuchrule"]);
        assert!(
            text.contains("contract.rule") && text.contains("nosuchrule"),
            "{text}"
        );
        let text = e(&["world.robots=3,4"]);
        assert!(text.contains("world.robots is both a grid axis"), "{text}");
        let mut both = grid_options(&dir, &["contract.rule=median"]);
        both.experiment = Some("e1-faulty".into());
        let text = format!(
            "{:#}",
            sweep(&both, &crate::progress::Quiet, None).unwrap_err()
        );
        assert!(text.contains("not both"), "{text}");
        assert!(!dir.exists());
    }

    #[test]
    fn a_sweep_refuses_to_add_results_of_other_settings_naming_both() {
        let dir = std::env::temp_dir().join(format!("swarmfl-sweep-mix-{}", std::process::id()));
        let point = dir.join("e2-faulty/byzantine-3");
        let point_overrides = vec!["byzantine.count=3".to_string()];
        let mut made = crate::summary::tests::example();
        made.summary.run.config_hash = "aaaaaaaaaaaaaaaa".into();
        made.sweep.overrides = vec!["byzantine.count=3".into(), "run.duration_s=300".into()];
        write_atomic(&point.join("seed1.json"), &made).unwrap();
        let same = check_settings(
            &point,
            "aaaaaaaaaaaaaaaa",
            &["run.duration_s=300".into()],
            &point_overrides,
        );
        assert!(same.is_ok(), "same settings add seeds: {same:?}");
        let err = check_settings(
            &point,
            "bbbbbbbbbbbbbbbb",
            &["run.duration_s=200".into()],
            &point_overrides,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("seed1.json was made with --set run.duration_s=300, this sweep uses --set run.duration_s=200"),
            "{err}"
        );
        let err = check_settings(
            &point,
            "bbbbbbbbbbbbbbbb",
            &["run.duration_s=300".into()],
            &point_overrides,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("another version's presets"), "{err}");
        assert!(check_settings(&dir.join("nothing"), "b", &[], &[]).is_ok());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

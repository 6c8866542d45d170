//! `swarmfl sweep`: the paper's experiments (docs/SPEC.md section 7) as a fixed task list of
//! (configuration point, seed) pairs, run locally in parallel or one shard at a time under a
//! cluster scheduler.
//!
//! The task list of an experiment with points `p = 0..P` (in the order [`experiment`] lists
//! them) and `R` runs is point-major: task `i = p * R + (seed - 1)`, seeds `1..=R`. A shard
//! `I/N` runs the tasks with `i % N == I`, so shards `0/N .. (N-1)/N` cover every task exactly
//! once whatever `N` is. Each task writes one result file
//! `DIR/<experiment>/<point>/seed<N>.json` (the run's summary JSON plus a `sweep` section naming
//! the task), atomically (temporary file + rename); a task whose result file exists and parses is
//! skipped, so a re-run resumes an interrupted sweep and a retried task simply overwrites.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::Context;
use swarmfl_core::config::{ByzantineKind, Config, Defence, Rule};
use swarmfl_core::contract::defences::ALL_DEFENCES;
use swarmfl_core::contract::rules::ALL_RULES;

use crate::progress::Progress;
use crate::run;

/// The experiments, in the order `swarmfl sweep --help` lists them.
pub const EXPERIMENTS: [&str; 8] = [
    "e0-baselines",
    "e1-expiration",
    "e1-faulty",
    "e2-faulty",
    "e2-malicious",
    "e3-smart",
    "e4-robustness",
    "e5-smart-defence",
];

/// Byzantine counts of `e4-robustness`: none (each rule's clean reference), a minority (3 of
/// 15: about 1.4 per 7-model round, near the rules' assumed f) and the largest minority (7 of
/// 15: about 3.3 per round, beyond every rule's f at quorum 7). Three counts keep the grid at
/// 9 + 9 x 12 x 2 = 225 points per seed (about 1.6 h of one core per seed at 2000 s);
/// 0, 1, 3, 5, 7 would be 441.
pub const E4_COUNTS: [u32; 3] = [0, 3, 7];

/// The assumed Byzantine count `e4-robustness` gives each rule: 2 (a rule built for the
/// expected 1.4 and a margin), except bulyan, whose maximum at quorum 7 is 1.
pub fn e4_assumed_f(rule: Rule) -> u32 {
    if rule == Rule::Bulyan {
        1
    } else {
        2
    }
}

/// One configuration point of an experiment's grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// The point's name: a directory name (e.g. `expiration-750`, `byzantine-3`).
    pub name: String,
    /// The grid value (expiration in s, or number of Byzantine robots), for plotting.
    pub x: f64,
    /// The configuration overrides that make this point from the experiment's preset.
    pub overrides: Vec<String>,
    /// The point's coordinates on further axes, by axis name (e4: `rule`, `attack`).
    pub tags: Vec<(&'static str, String)>,
}

/// One experiment: a preset, its grid of points and the paper's number of runs per point.
#[derive(Clone, Debug, PartialEq)]
pub struct Experiment {
    /// The experiment's id, also its preset's name.
    pub name: &'static str,
    /// What the grid varies, for axis labels (`data expiration (s)`, `Byzantine robots`).
    pub axis: &'static str,
    /// The grid, in task order.
    pub points: Vec<Point>,
    /// The paper's runs per point.
    pub runs: u32,
}

/// Looks an experiment up by id (docs/SPEC.md section 7).
pub fn experiment(name: &str) -> anyhow::Result<Experiment> {
    let byzantine_grid = || {
        (0..=7u32)
            .map(|count| Point {
                name: format!("byzantine-{count}"),
                x: f64::from(count),
                overrides: if count == 0 {
                    // Validation requires kind none with count 0.
                    vec!["byzantine.count=0".into(), "byzantine.kind=none".into()]
                } else {
                    vec![format!("byzantine.count={count}")]
                },
                tags: Vec::new(),
            })
            .collect()
    };
    Ok(match name {
        "e0-baselines" => Experiment {
            name: "e0-baselines",
            axis: "Byzantine robots",
            points: baselines_grid(),
            runs: 5,
        },
        "e1-expiration" => Experiment {
            name: "e1-expiration",
            axis: "data expiration (s)",
            points: [250u32, 500, 750, 1000, 1250]
                .iter()
                .map(|&s| Point {
                    name: format!("expiration-{s}"),
                    x: f64::from(s),
                    overrides: vec![format!("data.expiration_s={s}.0")],
                    tags: Vec::new(),
                })
                .collect(),
            runs: 5,
        },
        "e1-faulty" => Experiment {
            name: "e1-faulty",
            axis: "faulty robots",
            points: vec![Point {
                name: "faulty-1".into(),
                x: 1.0,
                overrides: Vec::new(),
                tags: Vec::new(),
            }],
            runs: 10,
        },
        "e2-faulty" => Experiment {
            name: "e2-faulty",
            axis: "faulty robots",
            points: byzantine_grid(),
            runs: 20,
        },
        "e2-malicious" => Experiment {
            name: "e2-malicious",
            axis: "malicious robots",
            points: byzantine_grid(),
            runs: 20,
        },
        "e3-smart" => Experiment {
            name: "e3-smart",
            axis: "smart robots",
            points: byzantine_grid(),
            runs: 18,
        },
        "e4-robustness" => Experiment {
            name: "e4-robustness",
            axis: "Byzantine robots",
            points: e4_points(),
            runs: 3,
        },
        "e5-smart-defence" => Experiment {
            name: "e5-smart-defence",
            axis: "Byzantine robots",
            points: e5_points(),
            runs: 3,
        },
        other => anyhow::bail!(
            "unknown experiment {other:?}; the experiments are {}",
            EXPERIMENTS.join(", ")
        ),
    })
}

/// The aggregations the baselines experiment compares, in grid order.
pub const AGGREGATIONS: [&str; 3] = ["chain", "gossip", "central"];

/// The grid of `e0-baselines`: each aggregation (`chain` with security on) without Byzantine
/// robots, with one faulty robot and with three malicious ones. A point's name is
/// `<aggregation>-<condition>` and its x the number of Byzantine robots.
fn baselines_grid() -> Vec<Point> {
    let conditions: [(&str, u32, &[&str]); 3] = [
        ("clean", 0, &["byzantine.count=0", "byzantine.kind=none"]),
        (
            "faulty-1",
            1,
            &["byzantine.count=1", "byzantine.kind=faulty"],
        ),
        (
            "malicious-3",
            3,
            &["byzantine.count=3", "byzantine.kind=malicious"],
        ),
    ];
    AGGREGATIONS
        .iter()
        .flat_map(|aggregation| {
            conditions.iter().map(move |(condition, count, overrides)| {
                let mut all = vec![format!("learn.aggregation={aggregation}")];
                all.extend(overrides.iter().map(|o| o.to_string()));
                Point {
                    name: format!("{aggregation}-{condition}"),
                    x: f64::from(*count),
                    overrides: all,
                    tags: vec![
                        ("aggregation", aggregation.to_string()),
                        ("condition", condition.to_string()),
                    ],
                }
            })
        })
        .collect()
}

/// The grid of `e4-robustness`, rule-major: per rule its clean point (no Byzantine robot),
/// then every attack at every non-zero count of [`E4_COUNTS`]. Point names are
/// `<rule>--<attack>--<count>` (`paper--none--0`, `krum--alie--3`).
fn e4_points() -> Vec<Point> {
    let mut points = Vec::new();
    for rule in ALL_RULES {
        let base = vec![
            format!("contract.rule={}", rule.name()),
            format!("contract.assumed_f={}", e4_assumed_f(rule)),
        ];
        for &count in &E4_COUNTS {
            let kinds: Vec<ByzantineKind> = if count == 0 {
                vec![ByzantineKind::None]
            } else {
                // smart-then-collude is e5-smart-defence's attack: the e4 grid stays as
                // published (12 attacks).
                ByzantineKind::ALL[1..]
                    .iter()
                    .copied()
                    .filter(|&k| k != ByzantineKind::SmartThenCollude)
                    .collect()
            };
            for kind in kinds {
                let mut overrides = base.clone();
                overrides.push(format!("byzantine.kind={}", kind.name()));
                overrides.push(format!("byzantine.count={count}"));
                points.push(Point {
                    name: format!("{}--{}--{count}", rule.name(), kind.name()),
                    x: f64::from(count),
                    overrides,
                    tags: vec![
                        ("rule", rule.name().to_string()),
                        ("attack", kind.name().to_string()),
                    ],
                });
            }
        }
    }
    points
}

/// Counts of `smart-then-collude` in `e5-smart-defence`: 3 (a minority that must first earn
/// a majority of the tokens), 5 and 7 (the paper's "from 3 on" up to the largest minority).
pub const E5_SWITCH_COUNTS: [u32; 3] = [3, 5, 7];

/// The grid of `e5-smart-defence`, defence-major (`none`, `agreement`, `innovation`): the
/// e3-smart grid (`smart` x 0..7), `smart-then-collude` x [`E5_SWITCH_COUNTS`], and the e2
/// check (`faulty` and `malicious` x 3). Point names are `<defence>--<attack>--<count>`
/// (`agreement--smart--3`, `none--none--0`).
fn e5_points() -> Vec<Point> {
    let mut points = Vec::new();
    for defence in ALL_DEFENCES {
        let mut grid: Vec<(ByzantineKind, u32)> = vec![(ByzantineKind::None, 0)];
        grid.extend((1..=7).map(|count| (ByzantineKind::Smart, count)));
        grid.extend(
            E5_SWITCH_COUNTS
                .iter()
                .map(|&count| (ByzantineKind::SmartThenCollude, count)),
        );
        grid.push((ByzantineKind::Faulty, 3));
        grid.push((ByzantineKind::Malicious, 3));
        for (kind, count) in grid {
            points.push(Point {
                name: format!("{}--{}--{count}", defence.name(), kind.name()),
                x: f64::from(count),
                overrides: vec![
                    format!("contract.defence={}", defence.name()),
                    format!("byzantine.kind={}", kind.name()),
                    format!("byzantine.count={count}"),
                ],
                tags: vec![
                    ("defence", defence.name().to_string()),
                    ("attack", kind.name().to_string()),
                ],
            });
        }
    }
    debug_assert!(points
        .iter()
        .all(|p| Defence::from_name(&p.tags[0].1).is_some()));
    points
}

/// One task: a configuration point and a seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Task {
    /// Position in the experiment's task list: `point_index * runs + (seed - 1)`.
    pub index: usize,
    /// The experiment's id (and preset).
    pub experiment: &'static str,
    /// Index of the point in the experiment's grid.
    pub point_index: usize,
    /// The point's name.
    pub point: String,
    /// The seed, `1..=runs`.
    pub seed: u64,
    /// All overrides: the point's, then the sweep's `--set` ones.
    pub overrides: Vec<String>,
}

/// Expands an experiment into its task list (point-major, seeds `1..=runs`), with `extra`
/// overrides appended to every task.
pub fn tasks(exp: &Experiment, runs: u32, extra: &[String]) -> Vec<Task> {
    let mut out = Vec::with_capacity(exp.points.len() * runs as usize);
    for (p, point) in exp.points.iter().enumerate() {
        for seed in 1..=u64::from(runs) {
            let mut overrides = point.overrides.clone();
            overrides.extend(extra.iter().cloned());
            out.push(Task {
                index: out.len(),
                experiment: exp.name,
                point_index: p,
                point: point.name.clone(),
                seed,
                overrides,
            });
        }
    }
    assert!(out
        .iter()
        .all(|t| t.index == t.point_index * runs as usize + (t.seed as usize - 1)));
    out
}

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

/// The result file of a task: `DIR/<experiment>/<point>/seed<N>.json`.
pub fn result_path(dir: &Path, experiment: &str, point: &str, seed: u64) -> PathBuf {
    dir.join(experiment)
        .join(point)
        .join(format!("seed{seed}.json"))
}

/// Whether a result file exists and parses as a summary (a JSON object with a `seed`).
pub fn is_done(path: &Path) -> bool {
    std::fs::read(path)
        .ok()
        .and_then(|bytes| serde_json::from_slice::<serde_json::Value>(&bytes).ok())
        .is_some_and(|v| v.get("seed").is_some_and(|s| s.is_u64()))
}

/// The sweep-wide `--set` overrides a result file was made with: its `sweep.overrides` minus
/// the point's own (which every result of the point shares).
pub fn extra_overrides(summary: &serde_json::Value, point_overrides: &[String]) -> Vec<String> {
    summary["sweep"]["overrides"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(str::to_string))
                .filter(|o| !point_overrides.contains(o))
                .collect()
        })
        .unwrap_or_default()
}

/// Shows overrides as the user typed them: `--set a=1 --set b=2`, or `no --set`.
pub fn show_overrides(overrides: &[String]) -> String {
    if overrides.is_empty() {
        "no --set".to_string()
    } else {
        overrides
            .iter()
            .map(|o| format!("--set {o}"))
            .collect::<Vec<_>>()
            .join(" ")
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
        let Some(summary) = std::fs::read(&file)
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        else {
            // An unreadable result is re-run (and overwritten) like a missing one.
            continue;
        };
        let theirs = summary["config_hash"].as_str().unwrap_or("(none)");
        if theirs == config_hash {
            continue;
        }
        let their_overrides = extra_overrides(&summary, point_overrides);
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

/// Writes `value` to `path` atomically: a temporary file in the same directory, then rename.
pub fn write_atomic(path: &Path, value: &serde_json::Value) -> anyhow::Result<()> {
    let dir = path.parent().context("result path has no directory")?;
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let name = path
        .file_name()
        .context("result path has no file name")?
        .to_string_lossy();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    std::fs::write(&tmp, serde_json::to_string_pretty(value)? + "\n")
        .with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path)
        .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))?;
    Ok(())
}

/// What `swarmfl sweep` was asked to do.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// The experiment's id.
    pub experiment: String,
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
}

/// Runs a sweep (or one shard of it).
pub fn sweep(opts: &SweepOptions) -> anyhow::Result<SweepOutcome> {
    let exp = experiment(&opts.experiment)?;
    let runs = opts.runs.unwrap_or(exp.runs);
    anyhow::ensure!(runs >= 1, "--runs must be at least 1");
    let all = tasks(&exp, runs, &opts.overrides);
    // Resolve every point's configuration up front: a bad --set fails before any run.
    let mut configs = Vec::with_capacity(exp.points.len());
    for point in &exp.points {
        let mut overrides = point.overrides.clone();
        overrides.extend(opts.overrides.iter().cloned());
        let config = Config::resolve(Some(exp.name), None, &overrides)
            .with_context(|| format!("{} point {}", exp.name, point.name))?;
        configs.push(config);
    }
    for (point, config) in exp.points.iter().zip(&configs) {
        check_settings(
            &opts.out.join(exp.name).join(&point.name),
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
        .filter(|t| !is_done(&result_path(&opts.out, t.experiment, &t.point, t.seed)))
        .collect();
    outcome.skipped = outcome.selected - todo.len();
    let jobs = opts
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .clamp(1, todo.len().max(1));
    // Runs side by side already fill the cores; a training's helper thread would only compete
    // with the other runs' world and ledger work (speed only: the bits are the same).
    swarmfl_core::learn::allow_two_thread_training(jobs == 1);
    eprintln!(
        "sweep {}: {} tasks in shard {}/{} ({} already done), {} runs per point, {} parallel",
        exp.name, outcome.selected, opts.shard.index, opts.shard.count, outcome.skipped, runs, jobs
    );
    let progress = Mutex::new(Progress::new(
        &format!("sweep {}", exp.name),
        "tasks",
        todo.len() as u64,
        false,
    ));
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let failed = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(task) = todo.get(k) else { break };
                let task_started = Instant::now();
                let result = run_task(opts, task, configs[task.point_index].clone());
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
                let mut progress = progress.lock().expect("no worker panics holding it");
                if result.is_err() {
                    progress.println(&line);
                }
                progress.set(finished as u64, || line.clone());
                if let Err(e) = result {
                    failed
                        .lock()
                        .expect("no worker panics while holding the lock")
                        .push((task.clone(), format!("{e:#}")));
                }
            });
        }
    });
    progress
        .into_inner()
        .expect("workers finished")
        .finish(todo.len() as u64);
    let mut failed = failed.into_inner().expect("workers finished");
    failed.sort_by_key(|(t, _)| t.index);
    outcome.ran = todo.len() - failed.len();
    outcome.failed = failed;
    outcome.wall_s = started.elapsed().as_secs_f64();
    Ok(outcome)
}

/// Runs one task and writes its result file.
fn run_task(opts: &SweepOptions, task: &Task, config: Config) -> anyhow::Result<()> {
    let result = result_path(&opts.out, task.experiment, &task.point, task.seed);
    let run_dir = if opts.keep_logs {
        result.with_extension("")
    } else {
        opts.out.join(".tmp").join(format!(
            "{}-{}-seed{}-{}",
            task.experiment,
            task.point,
            task.seed,
            std::process::id()
        ))
    };
    let outcome = run::run(config, task.seed, &run_dir, true);
    if !opts.keep_logs {
        // Best effort: a leftover temporary directory does not change any result.
        let _ = std::fs::remove_dir_all(&run_dir);
    }
    let mut summary = outcome?.summary;
    let map = summary
        .as_object_mut()
        .context("the run's summary is not a JSON object")?;
    map.insert(
        "sweep".into(),
        serde_json::json!({
            "experiment": task.experiment,
            "point": task.point,
            "seed": task.seed,
            "task": task.index,
            "overrides": task.overrides,
        }),
    );
    write_atomic(&result, &summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let vars: Vec<(String, String)> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |name: &str| vars.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone())
    }

    #[test]
    fn task_lists_have_the_papers_sizes_and_point_major_order() {
        let check = |name: &str, points: usize, runs: u32| {
            let exp = experiment(name).unwrap();
            assert_eq!(exp.points.len(), points, "{name}");
            assert_eq!(exp.runs, runs, "{name}");
            let list = tasks(&exp, exp.runs, &[]);
            assert_eq!(list.len(), points * runs as usize, "{name}");
            for (i, t) in list.iter().enumerate() {
                assert_eq!(t.index, i);
                assert_eq!(t.point_index, i / runs as usize);
                assert_eq!(t.seed, (i % runs as usize) as u64 + 1);
            }
        };
        check("e0-baselines", 9, 5);
        check("e1-expiration", 5, 5);
        check("e1-faulty", 1, 10);
        check("e2-faulty", 8, 20);
        check("e2-malicious", 8, 20);
        check("e3-smart", 8, 18);
        check("e5-smart-defence", 39, 3);
        assert!(experiment("e4").is_err());
    }

    #[test]
    fn every_point_resolves_to_a_valid_configuration() {
        for name in EXPERIMENTS {
            let exp = experiment(name).unwrap();
            for point in &exp.points {
                let config = Config::resolve(Some(name), None, &point.overrides)
                    .unwrap_or_else(|e| panic!("{name} {}: {e}", point.name));
                if name == "e1-expiration" {
                    assert_eq!(config.data.expiration_s, point.x);
                } else {
                    assert_eq!(f64::from(config.byzantine.count), point.x);
                }
                if name == "e0-baselines" {
                    let aggregation = point.name.split('-').next().unwrap();
                    assert_eq!(config.learn.aggregation.name(), aggregation);
                }
            }
        }
    }

    #[test]
    fn shards_cover_every_task_exactly_once() {
        for name in EXPERIMENTS {
            let exp = experiment(name).unwrap();
            for runs in [1u32, 3, exp.runs] {
                let list = tasks(&exp, runs, &["run.duration_s=600".to_string()]);
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

    #[test]
    fn a_sweep_refuses_to_add_results_of_other_settings_naming_both() {
        let dir = std::env::temp_dir().join(format!("swarmfl-sweep-mix-{}", std::process::id()));
        let point = dir.join("e2-faulty/byzantine-3");
        let point_overrides = vec!["byzantine.count=3".to_string()];
        let made = serde_json::json!({"seed": 1, "config_hash": "aaaaaaaaaaaaaaaa",
            "sweep": {"overrides": ["byzantine.count=3", "run.duration_s=300"]}});
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

    #[test]
    fn result_files_are_written_atomically_and_recognised() {
        let dir = std::env::temp_dir().join(format!("swarmfl-sweep-test-{}", std::process::id()));
        let path = result_path(&dir, "e2-faulty", "byzantine-3", 7);
        assert!(path.ends_with("e2-faulty/byzantine-3/seed7.json"));
        assert!(!is_done(&path));
        write_atomic(&path, &serde_json::json!({"seed": 7})).unwrap();
        assert!(is_done(&path));
        std::fs::write(&path, "{\"seed\": 7").unwrap();
        assert!(!is_done(&path), "a truncated file is not a finished task");
        write_atomic(&path, &serde_json::json!({"seed": 7, "x": 1})).unwrap();
        assert!(is_done(&path));
        let leftovers: Vec<_> = std::fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(leftovers.len(), 1, "no temporary file left: {leftovers:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

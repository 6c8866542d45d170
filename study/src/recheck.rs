//! Does a committed study still come from this build? (`swarmfl recheck`)
//!
//! A study directory (`reproduction/<study>/`) holds a sweep's result files under `results/`
//! and the report made from them beside it. Three checks, cheapest first, each naming the file
//! that fails:
//!
//! 1. **Configurations.** Every result file names its task (experiment, point, seed and
//!    overrides, the `sweep` section); today's presets must resolve that task to the
//!    configuration hash the file records. A preset or default that changed shows here,
//!    without running anything.
//! 2. **The report.** `swarmfl report` over the committed results must give the committed
//!    `numbers.csv`, `series.csv`, `timing.csv`, `report.md`, `e4-worst-case.csv`,
//!    `e4-benchmark-worst-case.csv` and `e4-heterogeneity-{cells,runs}.csv` byte for byte (the figures are drawn from the same
//!    numbers and are not compared).
//! 3. **Re-runs.** A few tasks per experiment (the `--tasks` with the smallest recorded wall
//!    time, ties by path, so the choice is fixed and CI stays short) are simulated again; the
//!    new summary must equal the committed file in every field but the wall-clock ones
//!    (`wall_s` and `timing`); a field the committed file does not have at all is new in the
//!    summary since the study was made and is not compared. The summary carries the final hash of the records, so one moved
//!    record anywhere in the run fails it. With `--max-task-s S`, only tasks recorded at most
//!    S seconds are candidates; an experiment with none is listed as not re-run.
//!
//! A task whose configuration runs the Solidity contract (`contract.engine = "evm"`) cannot be
//! resolved or run by a build without the `evm` cargo feature: in such a build its experiment
//! is named as needing that build and left out of checks 1 and 3 (never counted as passing);
//! a build with the feature checks it (CI runs both).
//!
//! A study whose README.md has a line starting with `Stale:` is not checked: the line says why
//! its results are not from the current build (a change that moved records and the re-make
//! still to do). `recheck` prints the reason, so a stale study is visible, never silent.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use anyhow::Context;
use swarmfl_core::config::{Config, ConfigError};

use crate::summary::{self, ResultFile, SweepTask};
use crate::{report, run};

/// The report's files that hold numbers (the figures are drawn from them).
const REPORT_FILES: [&str; 8] = [
    "numbers.csv",
    "series.csv",
    "timing.csv",
    "report.md",
    "e4-worst-case.csv",
    "e4-benchmark-worst-case.csv",
    "e4-heterogeneity-cells.csv",
    "e4-heterogeneity-runs.csv",
];

/// Summary fields measured by the wall clock: they differ from run to run by design.
const WALL_CLOCK_FIELDS: [&str; 2] = ["wall_s", "timing"];

/// One committed result file and the task it names.
#[derive(Clone, Debug)]
struct Committed {
    /// The file.
    path: PathBuf,
    /// Its contents as written, for the field-by-field comparison with a re-run.
    json: serde_json::Value,
    /// The configuration hash it records.
    config_hash: String,
    /// The task that made it (its `sweep` section).
    sweep: SweepTask,
    /// The recorded wall time of the run, seconds.
    wall_s: f64,
}

/// What a study's check found.
#[derive(Debug, Default)]
pub struct Findings {
    /// Result files checked for their configuration.
    pub files: usize,
    /// Tasks re-run.
    pub reran: usize,
    /// Experiments with no task under `--max-task-s`, with their fastest recorded wall time.
    pub not_rerun: Vec<(String, f64)>,
    /// Experiments whose tasks run the EVM engine, which this build lacks (cargo feature
    /// `evm`): neither resolved nor re-run here, with their number of result files.
    pub needs_evm: Vec<(String, usize)>,
    /// The problems, one line each, naming the file.
    pub problems: Vec<String>,
}

/// The reason after `Stale:` in the study's README.md, if it has such a line.
pub fn stale_reason(dir: &Path) -> anyhow::Result<Option<String>> {
    let readme = dir.join("README.md");
    let text = match std::fs::read_to_string(&readme) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", readme.display())),
    };
    Ok(text.lines().find_map(|line| {
        line.trim_start_matches(['>', ' ', '*'])
            .strip_prefix("Stale:")
            .map(|r| r.trim_start_matches(['*', ' ']).trim().to_string())
    }))
}

/// The three checks of one study.
///
/// `only`, when not empty, names the experiments whose tasks may be re-run (check 3); checks
/// 1 and 2 still cover every file.
pub fn check_study(
    dir: &Path,
    tasks: usize,
    max_task_s: Option<f64>,
    only: &[String],
    jobs: usize,
) -> anyhow::Result<Findings> {
    let results = dir.join("results");
    anyhow::ensure!(
        results.is_dir(),
        "{} has no results/ directory: a study directory holds a sweep's results/ and its report",
        dir.display()
    );
    let committed = load(&results)?;
    anyhow::ensure!(
        !committed.is_empty(),
        "no result files under {} (expected <experiment>/<point>/seed<N>.json)",
        results.display()
    );
    for name in only {
        if !committed.iter().any(|c| c.sweep.experiment == *name) {
            anyhow::bail!(
                "--experiment {name}: no result file of it under {} (its experiments: {})",
                results.display(),
                experiments(&committed).join(", ")
            );
        }
    }
    let mut findings = Findings::default();
    check_configurations(&committed, &mut findings);
    check_report(dir, &results, &mut findings)?;
    let runnable: Vec<Committed> = committed
        .into_iter()
        .filter(|c| {
            let evm = findings
                .needs_evm
                .iter()
                .any(|(e, _)| *e == c.sweep.experiment);
            let named = only.is_empty() || only.contains(&c.sweep.experiment);
            !evm && named
        })
        .collect();
    let (chosen, not_rerun) = choose(&runnable, tasks, max_task_s);
    findings.reran = chosen.len();
    findings.not_rerun = not_rerun;
    findings.problems.extend(rerun(&chosen, jobs));
    Ok(findings)
}

/// Every `seed<N>.json` under `results`, sorted by path.
fn load(results: &Path) -> anyhow::Result<Vec<Committed>> {
    let mut paths = Vec::new();
    collect(results, &mut paths)?;
    paths.sort();
    paths.iter().map(|p| parse(p)).collect()
}

/// The result files under `dir`, recursively (hidden directories, such as a sweep's `.tmp`, skipped).
fn collect(dir: &Path, out: &mut Vec<PathBuf>) -> anyhow::Result<()> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))?;
    for entry in entries {
        let entry = entry.with_context(|| format!("cannot read {}", dir.display()))?;
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') {
            continue;
        }
        if path.is_dir() {
            collect(&path, out)?;
        } else if name.starts_with("seed") && name.ends_with(".json") {
            out.push(path);
        }
    }
    Ok(())
}

/// Reads one result file and the task it names.
fn parse(path: &Path) -> anyhow::Result<Committed> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let json: serde_json::Value = serde_json::from_slice(&bytes).with_context(|| {
        format!(
            "{} is not valid JSON: restore it from git or re-run its task with `swarmfl sweep`",
            path.display()
        )
    })?;
    let made = ResultFile::parse(&bytes, path)?;
    Ok(Committed {
        path: path.to_path_buf(),
        json,
        config_hash: made.summary.run.config_hash,
        sweep: made.sweep,
        wall_s: made.summary.wall_s,
    })
}

/// Check 1: today's presets give every file's recorded configuration hash. A file whose task
/// needs the EVM engine in a build without it is counted in `needs_evm` instead.
fn check_configurations(committed: &[Committed], findings: &mut Findings) {
    for c in committed {
        let resolved = resolve(c);
        if matches!(&resolved, Err(e) if needs_evm_feature(e)) {
            match findings
                .needs_evm
                .iter_mut()
                .find(|(experiment, _)| *experiment == c.sweep.experiment)
            {
                Some((_, files)) => *files += 1,
                None => findings.needs_evm.push((c.sweep.experiment.clone(), 1)),
            }
            continue;
        }
        findings.files += 1;
        match resolved {
            Ok(config) => {
                let today = config.hash().to_hex().to_string();
                let theirs = c.config_hash.as_str();
                if today != theirs {
                    findings.problems.push(format!(
                        "{}: made under configuration {}, today's presets give {} for \
                         {} seed {} (a preset or a default changed)",
                        c.path.display(),
                        short(theirs),
                        short(&today),
                        c.sweep.experiment,
                        c.sweep.seed
                    ));
                }
            }
            Err(e) => findings.problems.push(format!(
                "{}: its task no longer resolves: {e:#}",
                c.path.display()
            )),
        }
    }
}

/// Whether a resolution failed only because this build has no EVM engine (cargo feature
/// `evm`) and the task sets `contract.engine = "evm"`.
fn needs_evm_feature(error: &anyhow::Error) -> bool {
    !cfg!(feature = "evm")
        && matches!(
            error.downcast_ref::<ConfigError>(),
            Some(ConfigError::OutOfRange { key, value, .. })
                if key == "contract.engine" && value == "evm"
        )
}

/// The configuration of a committed task under today's presets.
fn resolve(c: &Committed) -> anyhow::Result<Config> {
    Ok(Config::resolve(
        Some(&c.sweep.preset),
        None,
        &c.sweep.overrides,
    )?)
}

/// Check 2: the report of the committed results equals the committed report files.
fn check_report(dir: &Path, results: &Path, findings: &mut Findings) -> anyhow::Result<()> {
    let scratch = scratch_dir("report")?;
    let made = report::report(results, &scratch);
    if let Err(e) = made {
        let _ = std::fs::remove_dir_all(&scratch);
        findings.problems.push(format!(
            "{}: `swarmfl report` fails on it: {e:#}",
            results.display()
        ));
        return Ok(());
    }
    for name in REPORT_FILES {
        let committed = dir.join(name);
        let new = scratch.join(name);
        match (std::fs::read(&committed), std::fs::read(&new)) {
            (Ok(a), Ok(b)) if a == b => {}
            (Ok(a), Ok(b)) => findings.problems.push(format!(
                "{}: differs from `swarmfl report {}` ({})",
                committed.display(),
                results.display(),
                first_difference(&a, &b)
            )),
            (Err(_), Ok(_)) => findings.problems.push(format!(
                "{}: missing (`swarmfl report` writes it)",
                committed.display()
            )),
            (Ok(_), Err(_)) => findings.problems.push(format!(
                "{}: committed but `swarmfl report` no longer writes it",
                committed.display()
            )),
            (Err(_), Err(_)) => {}
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    Ok(())
}

/// Where two texts first differ: the line number and both lines, shortened.
fn first_difference(committed: &[u8], new: &[u8]) -> String {
    let a = String::from_utf8_lossy(committed);
    let b = String::from_utf8_lossy(new);
    let mut la = a.lines();
    let mut lb = b.lines();
    let mut line = 1usize;
    loop {
        match (la.next(), lb.next()) {
            (Some(x), Some(y)) if x == y => line += 1,
            (x, y) => {
                return format!(
                    "line {line}: committed {:?}, report gives {:?}",
                    clip(x.unwrap_or("(end of file)")),
                    clip(y.unwrap_or("(end of file)"))
                )
            }
        }
    }
}

/// At most 80 characters of `s`.
fn clip(s: &str) -> String {
    if s.chars().count() <= 80 {
        s.to_string()
    } else {
        s.chars().take(77).collect::<String>() + "..."
    }
}

/// The experiments of `committed`, sorted, each once.
fn experiments(committed: &[Committed]) -> Vec<&str> {
    let mut names: Vec<&str> = committed
        .iter()
        .map(|c| c.sweep.experiment.as_str())
        .collect();
    names.sort_unstable();
    names.dedup();
    names
}

/// Check 3's tasks: per experiment, the `per_experiment` files with the smallest recorded wall
/// time (ties by path), in path order, leaving out tasks recorded over `max_task_s`; and the
/// experiments (with `per_experiment` > 0) left with no task that way, with their fastest time.
fn choose(
    committed: &[Committed],
    per_experiment: usize,
    max_task_s: Option<f64>,
) -> (Vec<Committed>, Vec<(String, f64)>) {
    let mut chosen = Vec::new();
    let mut not_rerun = Vec::new();
    for e in experiments(committed) {
        let mut of: Vec<&Committed> = committed
            .iter()
            .filter(|c| c.sweep.experiment == e)
            .collect();
        of.sort_by(|a, b| a.wall_s.total_cmp(&b.wall_s).then(a.path.cmp(&b.path)));
        let fastest = of.first().map_or(f64::INFINITY, |c| c.wall_s);
        let under = of
            .into_iter()
            .filter(|c| max_task_s.is_none_or(|bound| c.wall_s <= bound));
        let before = chosen.len();
        chosen.extend(under.take(per_experiment).cloned());
        if per_experiment > 0 && chosen.len() == before {
            not_rerun.push((e.to_string(), fastest));
        }
    }
    chosen.sort_by(|a, b| a.path.cmp(&b.path));
    (chosen, not_rerun)
}

/// Check 3: re-runs `chosen` on `jobs` threads; one problem line per task that differs.
fn rerun(chosen: &[Committed], jobs: usize) -> Vec<String> {
    let jobs = jobs.clamp(1, chosen.len().max(1));
    swarmfl_core::learn::allow_two_thread_training(jobs == 1);
    let next = AtomicUsize::new(0);
    let problems = Mutex::new(vec![None; chosen.len()]);
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(task) = chosen.get(k) else { break };
                let problem = match rerun_one(task) {
                    Ok(None) => None,
                    Ok(Some(difference)) => Some(format!(
                        "{}: re-run differs: {difference}",
                        task.path.display()
                    )),
                    Err(e) => Some(format!("{}: re-run failed: {e:#}", task.path.display())),
                };
                problems.lock().expect("no worker panics holding it")[k] = problem;
            });
        }
    });
    problems
        .into_inner()
        .expect("workers finished")
        .into_iter()
        .flatten()
        .collect()
}

/// Simulates one committed task again; the first differing field, if any.
fn rerun_one(task: &Committed) -> anyhow::Result<Option<String>> {
    let config = resolve(task)?;
    let out = scratch_dir("run")?;
    let outcome = run::RunRequest::new(config, task.sweep.seed, &out).run(&crate::progress::Quiet);
    let _ = std::fs::remove_dir_all(&out);
    // The sweep section is the task's name, written by `sweep` beside the summary.
    let new = ResultFile {
        summary: outcome?.summary,
        sweep: task.sweep.clone(),
    };
    // Through text and back, as the committed file went, so both sides parse the same digits.
    let new: serde_json::Value = serde_json::from_str(&summary::to_json(&new)?)?;
    Ok(difference(&task.json, &new, ""))
}

/// The first path where `committed` and `new` differ, wall-clock fields at the top level apart.
/// A field only `new` has is not a difference: summaries gain fields as the engine learns to
/// measure more, and a committed study made before stays valid (every field it has must still
/// match, the records' hash among them). A field only `committed` has is one.
fn difference(committed: &serde_json::Value, new: &serde_json::Value, at: &str) -> Option<String> {
    use serde_json::Value;
    match (committed, new) {
        (Value::Object(a), Value::Object(b)) => {
            let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
            keys.sort_unstable();
            keys.dedup();
            for key in keys {
                if at.is_empty() && WALL_CLOCK_FIELDS.contains(&key.as_str()) {
                    continue;
                }
                let path = if at.is_empty() {
                    key.clone()
                } else {
                    format!("{at}.{key}")
                };
                match (a.get(key), b.get(key)) {
                    (Some(x), Some(y)) => {
                        if let Some(d) = difference(x, y, &path) {
                            return Some(d);
                        }
                    }
                    (Some(_), None) => return Some(format!("{path}: no longer in the summary")),
                    // A field the committed file lacks was added to the summary after the
                    // study was made: new, not a divergence (the records' hash, compared
                    // field by field above, still catches any moved record).
                    (None, Some(_)) | (None, None) => {}
                }
            }
            None
        }
        (Value::Array(a), Value::Array(b)) => {
            if a.len() != b.len() {
                return Some(format!(
                    "{at}: {} entries committed, {} now",
                    a.len(),
                    b.len()
                ));
            }
            a.iter()
                .zip(b)
                .enumerate()
                .find_map(|(i, (x, y))| difference(x, y, &format!("{at}[{i}]")))
        }
        (x, y) if x == y => None,
        (x, y) => Some(format!(
            "{at}: committed {}, now {}",
            clip(&x.to_string()),
            clip(&y.to_string())
        )),
    }
}

/// A fresh scratch directory under the system's temporary directory.
fn scratch_dir(what: &str) -> anyhow::Result<PathBuf> {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "swarmfl-recheck-{what}-{}-{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::SeqCst)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    Ok(dir)
}

/// The first 12 characters of a hash.
fn short(hash: &str) -> &str {
    &hash[..hash.len().min(12)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results;
    use serde_json::json;

    #[test]
    fn the_first_difference_is_named_by_its_path_and_wall_clock_fields_are_ignored() {
        let a = json!({"wall_s": 1.0, "timing": {"x": 1}, "contract": {"rounds": 3,
            "loss": [0.5, 0.25]}, "final_hash": "aa"});
        let mut b = a.clone();
        b["wall_s"] = json!(2.0);
        b["timing"]["x"] = json!(9);
        assert_eq!(difference(&a, &b, ""), None);
        b["contract"]["loss"][1] = json!(0.3);
        assert_eq!(
            difference(&a, &b, "").as_deref(),
            Some("contract.loss[1]: committed 0.25, now 0.3")
        );
        // A field added to the summary after the study was made is new, not a divergence; a
        // field the summary no longer has is one.
        let mut c = a.clone();
        c["contract"]["extra"] = json!(1);
        assert_eq!(difference(&a, &c, ""), None);
        assert_eq!(
            difference(&c, &a, "").as_deref(),
            Some("contract.extra: no longer in the summary")
        );
        // A nested field named like a wall-clock one is compared.
        let mut d = a.clone();
        d["contract"]["wall_s"] = json!(1);
        let mut e = d.clone();
        e["contract"]["wall_s"] = json!(2);
        assert!(difference(&d, &e, "").is_some());
    }

    #[test]
    fn a_stale_line_is_found_in_the_readme() {
        let dir = scratch_dir("test-stale").unwrap();
        assert_eq!(stale_reason(&dir).unwrap(), None);
        std::fs::write(dir.join("README.md"), "# A study\n\nNothing here.\n").unwrap();
        assert_eq!(stale_reason(&dir).unwrap(), None);
        std::fs::write(
            dir.join("README.md"),
            "# A study\n\n**Stale:** made before the activations changed (#31).\n",
        )
        .unwrap();
        assert_eq!(
            stale_reason(&dir).unwrap().as_deref(),
            Some("made before the activations changed (#31).")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn tasks_are_chosen_by_recorded_wall_time_per_experiment() {
        let file = |path: &str, experiment: &str, wall_s: f64| Committed {
            path: PathBuf::from(path),
            json: json!({}),
            config_hash: String::new(),
            sweep: SweepTask {
                experiment: experiment.into(),
                point: "p".into(),
                seed: 1,
                task: 0,
                overrides: vec![],
                preset: experiment.into(),
                point_index: 0,
                x: None,
            },
            wall_s,
        };
        let all = vec![
            file("a/p/seed1.json", "a", 3.0),
            file("a/p/seed2.json", "a", 1.0),
            file("a/q/seed1.json", "a", 1.0),
            file("b/p/seed1.json", "b", 5.0),
        ];
        let paths = |chosen: &[Committed]| -> Vec<String> {
            chosen
                .iter()
                .map(|c| c.path.display().to_string())
                .collect()
        };
        let (chosen, not_rerun) = choose(&all, 2, None);
        assert_eq!(
            paths(&chosen),
            ["a/p/seed2.json", "a/q/seed1.json", "b/p/seed1.json"]
        );
        assert!(not_rerun.is_empty());
        // A bound leaves out the slow tasks and names the experiment left with none.
        let (chosen, not_rerun) = choose(&all, 2, Some(2.0));
        assert_eq!(paths(&chosen), ["a/p/seed2.json", "a/q/seed1.json"]);
        assert_eq!(not_rerun, [("b".to_string(), 5.0)]);
        let (chosen, _) = choose(&all, 3, Some(3.0));
        assert_eq!(paths(&chosen).len(), 3);
    }

    /// A tiny study passes; editing one committed number, the report or the configuration each
    /// fails, naming the file.
    #[test]
    fn a_study_passes_until_a_committed_file_is_edited() {
        use crate::sweep::{sweep, Shard, SweepOptions};
        let dir = scratch_dir("test-study").unwrap();
        let results = dir.join("results");
        let outcome = sweep(
            &SweepOptions {
                experiment: Some("e1-faulty".into()),
                preset: None,
                grid: Vec::new(),
                out: results.clone(),
                runs: Some(1),
                jobs: Some(1),
                shard: Shard::ALL,
                overrides: vec!["run.duration_s=40".into(), "world.robots=6".into()],
                keep_logs: false,
            },
            &crate::progress::Quiet,
            None,
        )
        .unwrap();
        assert_eq!((outcome.ran, outcome.failed.len()), (1, 0));
        report::report(&results, &dir).unwrap();
        let clean = check_study(&dir, 1, None, &[], 1).unwrap();
        assert_eq!(clean.problems, Vec::<String>::new());
        assert_eq!((clean.files, clean.reran), (1, 1));

        let file = results.join("e1-faulty/faulty-1/seed1.json");
        let original = std::fs::read_to_string(&file).unwrap();
        // A number of the run edited (the records' hash stays, so only the re-run sees it).
        let mut edited = ResultFile::parse(original.as_bytes(), &file).unwrap();
        edited.summary.run.world.collisions = 12345;
        results::write_atomic(&file, &edited).unwrap();
        let found = check_study(&dir, 1, None, &[], 1).unwrap().problems;
        assert!(
            found
                .iter()
                .any(|p| p.contains("seed1.json: re-run differs: world.collisions")),
            "{found:?}"
        );
        // A wall-clock field edited: not a difference.
        let mut timed = ResultFile::parse(original.as_bytes(), &file).unwrap();
        timed.summary.wall_s = 99.0;
        results::write_atomic(&file, &timed).unwrap();
        report::report(&results, &dir).unwrap();
        assert_eq!(
            check_study(&dir, 1, None, &[], 1).unwrap().problems,
            Vec::<String>::new()
        );
        // Another configuration hash: named without a re-run.
        let mut other = ResultFile::parse(original.as_bytes(), &file).unwrap();
        other.summary.run.config_hash = "00112233445566778899".into();
        results::write_atomic(&file, &other).unwrap();
        let found = check_study(&dir, 0, None, &[], 1).unwrap().problems;
        assert!(
            found
                .iter()
                .any(|p| p.contains("made under configuration 001122334455")),
            "{found:?}"
        );
        // Naming the experiment re-runs it; naming one the study does not have is an error.
        std::fs::write(&file, &original).unwrap();
        let named = check_study(&dir, 1, None, &["e1-faulty".into()], 1).unwrap();
        assert_eq!((named.files, named.reran), (1, 1));
        let unknown = check_study(&dir, 1, None, &["e2-malicious".into()], 1).unwrap_err();
        assert!(
            format!("{unknown:#}").contains("--experiment e2-malicious: no result file of it"),
            "{unknown:#}"
        );
        // A task on the EVM engine: a build without it names the experiment and checks none of
        // its files (never passing them); a build with it resolves the task, whose
        // configuration is then not the recorded one.
        let mut evm = ResultFile::parse(original.as_bytes(), &file).unwrap();
        evm.sweep.overrides.push("contract.engine=evm".into());
        results::write_atomic(&file, &evm).unwrap();
        report::report(&results, &dir).unwrap();
        let found = check_study(&dir, 1, None, &[], 1).unwrap();
        if cfg!(feature = "evm") {
            assert!(found.needs_evm.is_empty());
            assert!(
                found
                    .problems
                    .iter()
                    .any(|p| p.contains("made under configuration")),
                "{:?}",
                found.problems
            );
        } else {
            assert_eq!(found.needs_evm, [("e1-faulty".to_string(), 1)]);
            assert_eq!((found.files, found.reran), (0, 0));
            assert_eq!(found.problems, Vec::<String>::new());
        }
        // The committed report edited.
        std::fs::write(&file, &original).unwrap();
        report::report(&results, &dir).unwrap();
        let numbers = dir.join("numbers.csv");
        let text = std::fs::read_to_string(&numbers).unwrap();
        std::fs::write(&numbers, text.replacen('1', "2", 1)).unwrap();
        let found = check_study(&dir, 0, None, &[], 1).unwrap().problems;
        assert!(
            found
                .iter()
                .any(|p| p.contains("numbers.csv: differs from `swarmfl report")),
            "{found:?}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn report_differences_name_the_line() {
        assert_eq!(
            first_difference(b"a\nb\nc\n", b"a\nB\nc\n"),
            "line 2: committed \"b\", report gives \"B\""
        );
        assert_eq!(
            first_difference(b"a\n", b"a\nb\n"),
            "line 2: committed \"(end of file)\", report gives \"b\""
        );
    }
}

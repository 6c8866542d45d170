//! Reading a results directory: every `DIR/<experiment>/<point>/seed<N>.json`, refused when
//! damaged or when a point mixes configurations, sorted so that no sum depends on the order
//! the files were found in.

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::experiments::{self, EXPERIMENTS};
use crate::results;
use crate::summary::ResultFile;

/// One run's result file.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// The experiment.
    pub experiment: String,
    /// The configuration point.
    pub point: String,
    /// The seed.
    pub seed: u64,
    /// The file: the run's summary and the task that made it.
    pub result: ResultFile,
}

/// Reads every `DIR/<experiment>/<point>/seed<N>.json`, sorted by experiment, point (grid order
/// for known experiments, else by name) and seed. Refuses (naming the files) damaged result
/// files and points that mix configurations. Returns the results and notes for the report.
pub fn load(dir: &Path) -> anyhow::Result<(Vec<RunResult>, Vec<String>)> {
    let mut results = Vec::new();
    let notes = Vec::new();
    let mut bad = Vec::new();
    let entries = |d: &Path| -> anyhow::Result<Vec<PathBuf>> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(d)
            .with_context(|| format!("cannot read {}", d.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .collect();
        v.sort();
        Ok(v)
    };
    for exp_dir in entries(dir)?.into_iter().filter(|p| p.is_dir()) {
        let experiment = file_name(&exp_dir);
        if experiment.starts_with('.') {
            continue;
        }
        for point_dir in entries(&exp_dir)?.into_iter().filter(|p| p.is_dir()) {
            let point = file_name(&point_dir);
            for file in entries(&point_dir)? {
                let name = file_name(&file);
                let Some(seed) = name
                    .strip_prefix("seed")
                    .and_then(|s| s.strip_suffix(".json"))
                    .and_then(|s| s.parse::<u64>().ok())
                else {
                    continue;
                };
                let bytes = std::fs::read(&file).unwrap_or_default();
                match serde_json::from_slice::<ResultFile>(&bytes) {
                    Ok(result) if result.summary.run.seed == seed => results.push(RunResult {
                        experiment: experiment.clone(),
                        point: point.clone(),
                        seed,
                        result,
                    }),
                    Ok(_) => bad.push(format!(
                        "{}: a JSON file, but not the summary of seed {seed} (its `seed` differs)",
                        file.display()
                    )),
                    Err(e) if e.is_data() => bad.push(format!(
                        "{}: a JSON file, but not a result file this version reads: {e} (written \
                         by another version; re-run the sweep to redo that task)",
                        file.display()
                    )),
                    Err(_) => bad.push(format!(
                        "{}: not readable as JSON (truncated or damaged; delete it and re-run \
                         the sweep to redo that task)",
                        file.display()
                    )),
                }
            }
        }
    }
    anyhow::ensure!(
        bad.is_empty(),
        "{} result file(s) under {} are damaged, no report written:\n  {}",
        bad.len(),
        dir.display(),
        bad.join("\n  ")
    );
    sort(&mut results);
    check_one_configuration_per_point(dir, &results)?;
    Ok((results, notes))
}

/// Refuses a point whose results were made under different configurations (other `--set`
/// values, or another version's presets): their mean would describe no experiment. Names a
/// file of each configuration and its settings.
fn check_one_configuration_per_point(dir: &Path, results: &[RunResult]) -> anyhow::Result<()> {
    for group in results.chunk_by(|a, b| a.experiment == b.experiment && a.point == b.point) {
        let first = &group[0];
        let hash = |r: &RunResult| r.result.summary.run.config_hash.clone();
        let Some(other) = group.iter().find(|r| hash(r) != hash(first)) else {
            continue;
        };
        let point_overrides = experiments::experiment(&first.experiment)
            .ok()
            .and_then(|e| e.points.into_iter().find(|p| p.name == first.point))
            .map(|p| p.overrides)
            .unwrap_or_default();
        let settings = |r: &RunResult| {
            let h = hash(r);
            format!(
                "{} (configuration {})",
                results::show_overrides(&results::extra_overrides(
                    &r.result.sweep,
                    &point_overrides
                )),
                &h[..h.len().min(12)]
            )
        };
        let path = |r: &RunResult| results::result_path(dir, &r.experiment, &r.point, r.seed);
        anyhow::bail!(
            "{} {} mixes results of different settings, no report written: {} was made with {}, \
             {} with {}. Keep each setting in its own results directory",
            first.experiment,
            first.point,
            path(first).display(),
            settings(first),
            path(other).display(),
            settings(other)
        );
    }
    Ok(())
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Sorts results by experiment (the sweep's order, unknown ones after by name), point (grid
/// order, a `--grid` sweep's recorded position, else after by name) and seed.
pub fn sort(results: &mut [RunResult]) {
    let key = |r: &RunResult| {
        let exp_rank = EXPERIMENTS
            .iter()
            .position(|e| *e == r.experiment)
            .unwrap_or(usize::MAX);
        // A --grid sweep's points are not built in: their files record their grid position.
        let point_rank = experiments::experiment(&r.experiment)
            .ok()
            .and_then(|e| e.points.iter().position(|p| p.name == r.point))
            .unwrap_or(r.result.sweep.point_index);
        (
            exp_rank,
            r.experiment.clone(),
            point_rank,
            r.point.clone(),
            r.seed,
        )
    };
    results.sort_by_cached_key(key);
}

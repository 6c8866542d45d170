//! `swarmfl report`: merges a sweep's result files and computes, per experiment and
//! configuration point, means and 95 % confidence intervals over runs, then draws the paper's
//! figures and writes `report.md` with a table of the numbers.
//!
//! Statistics: for `n` runs with mean `m` and sample standard deviation `s`, the 95 % interval
//! is `m +- t(0.975, n-1) * s / sqrt(n)` (Student t; no interval for `n < 2`). Curves over time
//! use 100 s bins: the loss of a run at time `t` is the `loss_by_round` entry of the last round
//! whose `round_times_s` is at or before `t` (a run with no round yet does not count in that
//! bin); chain size at `t` is the last `ledger.chain_bytes` sample at or before `t`.
//! Results are sorted by experiment, point (in the grid's order) and seed before any sum, so the
//! numbers do not depend on file discovery order. `numbers.csv` and `series.csv` hold every
//! deterministic number (shards merged or one local sweep give identical files); wall-clock
//! times are kept apart in `timing.csv`.

mod defence;
mod plots;
mod robustness;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use serde_json::Value;

use crate::cli::ReportArgs;
use crate::experiments::{self, EXPERIMENTS};
use crate::results;

/// Width of the time bins of the curves, in simulated seconds.
pub const BIN_S: f64 = 100.0;

/// One run's result file.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// The experiment.
    pub experiment: String,
    /// The configuration point.
    pub point: String,
    /// The seed.
    pub seed: u64,
    /// The summary JSON.
    pub summary: Value,
}

/// A mean with its 95 % confidence half-width over `n` values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stat {
    /// Number of values.
    pub n: usize,
    /// Their mean.
    pub mean: f64,
    /// Half-width of the 95 % Student-t interval (None for fewer than 2 values).
    pub ci: Option<f64>,
}

impl Stat {
    /// The statistic of `values` (in the order given: the sum is sequential).
    pub fn of(values: &[f64]) -> Option<Stat> {
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let ci = (n >= 2).then(|| {
            let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64;
            t_975(n - 1) * var.sqrt() / (n as f64).sqrt()
        });
        Some(Stat { n, mean, ci })
    }

    /// `mean +- ci` as text.
    fn text(self, digits: usize) -> String {
        match self.ci {
            Some(ci) => format!("{:.digits$} ± {:.digits$}", self.mean, ci),
            None => format!("{:.digits$}", self.mean),
        }
    }
}

/// The 0.975 quantile of Student's t with `df` degrees of freedom: exact table values for
/// df 1..=30, then interpolation in 1/df between 30, 40, 60, 120 and infinity.
pub fn t_975(df: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    assert!(df >= 1, "t quantile needs at least one degree of freedom");
    if df <= 30 {
        return TABLE[df - 1];
    }
    const TAIL: [(f64, f64); 5] = [
        (30.0, 2.042),
        (40.0, 2.021),
        (60.0, 2.000),
        (120.0, 1.980),
        (f64::INFINITY, 1.960),
    ];
    let inv = 1.0 / df as f64;
    for w in TAIL.windows(2) {
        let (a, b) = ((1.0 / w[0].0, w[0].1), (1.0 / w[1].0, w[1].1));
        if inv <= a.0 && inv >= b.0 {
            return b.1 + (a.1 - b.1) * (inv - b.0) / (a.0 - b.0);
        }
    }
    1.960
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
                let parsed = std::fs::read(&file)
                    .ok()
                    .and_then(|b| serde_json::from_slice::<Value>(&b).ok());
                match parsed {
                    Some(summary) if summary.get("seed").and_then(Value::as_u64) == Some(seed) => {
                        results.push(RunResult {
                            experiment: experiment.clone(),
                            point: point.clone(),
                            seed,
                            summary,
                        })
                    }
                    Some(_) => bad.push(format!(
                        "{}: a JSON file, but not the summary of seed {seed} (its `seed` differs \
                         or is missing)",
                        file.display()
                    )),
                    None => bad.push(format!(
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
        let hash = |r: &RunResult| r.summary["config_hash"].as_str().unwrap_or("").to_string();
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
                results::show_overrides(&results::extra_overrides(&r.summary, &point_overrides)),
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
/// order, unknown ones after by name) and seed.
pub fn sort(results: &mut [RunResult]) {
    let key = |r: &RunResult| {
        let exp_rank = EXPERIMENTS
            .iter()
            .position(|e| *e == r.experiment)
            .unwrap_or(usize::MAX);
        let point_rank = experiments::experiment(&r.experiment)
            .ok()
            .and_then(|e| e.points.iter().position(|p| p.name == r.point))
            .unwrap_or(usize::MAX);
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

/// A curve over time: per bin end time, the statistic over the runs that have a value.
pub type Curve = Vec<(f64, Stat)>;

/// Everything computed for one configuration point.
#[derive(Clone, Debug)]
pub struct PointStats {
    /// The point's name.
    pub point: String,
    /// The grid value (NaN if the point is not in the experiment's grid).
    pub x: f64,
    /// The seeds present, ascending.
    pub seeds: Vec<u64>,
    /// Loss over time (empty without `contract` sections).
    pub loss: Curve,
    /// Held-out loss of the aggregated model over time (the last aggregation at or before each
    /// bin's end; `gossip`: of whichever robot merged last).
    pub heldout: Curve,
    /// Chain size over time in MB (empty without `ledger` sections).
    pub chain_mb: Curve,
    /// Scalar metrics by name (only those present in the results).
    pub metrics: BTreeMap<&'static str, Stat>,
    /// Wall-clock seconds per run (not deterministic; kept apart).
    pub wall_s: Option<Stat>,
    /// Results lacking a section the report uses, by section name.
    pub missing: BTreeMap<&'static str, usize>,
}

/// Everything computed for one experiment.
#[derive(Clone, Debug)]
pub struct ExperimentStats {
    /// The experiment's id.
    pub name: String,
    /// The grid's axis label.
    pub axis: String,
    /// Per point, in grid order.
    pub points: Vec<PointStats>,
}

/// The loss of a run at time `t`: the last round closed at or before `t`.
fn loss_at(times: &[f64], losses: &[f64], t: f64) -> Option<f64> {
    let closed = times.iter().take_while(|&&rt| rt <= t).count();
    closed
        .checked_sub(1)
        .and_then(|r| losses.get(r).copied())
        .filter(|v| v.is_finite())
}

fn f64s(v: Option<&Value>) -> Option<Vec<f64>> {
    v?.as_array()?.iter().map(Value::as_f64).collect()
}

fn curve(sim_time_s: f64, per_run: &[Box<dyn Fn(f64) -> Option<f64> + '_>]) -> Curve {
    if per_run.is_empty() {
        return Vec::new();
    }
    let bins = (sim_time_s / BIN_S).ceil().max(1.0) as u64;
    (1..=bins)
        .filter_map(|b| {
            let t = (b as f64 * BIN_S).min(sim_time_s);
            let values: Vec<f64> = per_run.iter().filter_map(|f| f(t)).collect();
            Stat::of(&values).map(|s| (t, s))
        })
        .collect()
}

/// Computes the statistics of sorted results.
pub fn aggregate(results: &[RunResult]) -> Vec<ExperimentStats> {
    let mut out: Vec<ExperimentStats> = Vec::new();
    for r in results {
        if out.last().is_none_or(|e| e.name != r.experiment) {
            let exp = experiments::experiment(&r.experiment).ok();
            out.push(ExperimentStats {
                name: r.experiment.clone(),
                axis: exp.map_or_else(|| "point".to_string(), |e| e.axis.to_string()),
                points: Vec::new(),
            });
        }
    }
    for exp in &mut out {
        let mine: Vec<&RunResult> = results
            .iter()
            .filter(|r| r.experiment == exp.name)
            .collect();
        let mut names: Vec<&str> = Vec::new();
        for r in &mine {
            if names.last() != Some(&r.point.as_str()) {
                names.push(&r.point);
            }
        }
        let grid = experiments::experiment(&exp.name).ok();
        for name in names {
            let runs: Vec<&RunResult> = mine.iter().copied().filter(|r| r.point == name).collect();
            let x = grid
                .as_ref()
                .and_then(|g| g.points.iter().find(|p| p.name == name))
                .map_or(f64::NAN, |p| p.x);
            exp.points.push(point_stats(name, x, &runs));
        }
    }
    out
}

fn point_stats(name: &str, x: f64, runs: &[&RunResult]) -> PointStats {
    let mut missing = BTreeMap::new();
    let mut metric_values: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let mut push = |key: &'static str, v: Option<f64>| {
        if let Some(v) = v.filter(|v| v.is_finite()) {
            metric_values.entry(key).or_default().push(v);
        }
    };
    let sim_time_s = runs
        .iter()
        .filter_map(|r| r.summary.get("sim_time_s").and_then(Value::as_f64))
        .fold(0.0f64, f64::max);
    let mut loss_runs: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let mut heldout_runs: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let mut chain_runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut walls = Vec::new();
    for r in runs {
        let s = &r.summary;
        for section in ["contract", "tokens", "ledger"] {
            if s.get(section).is_none_or(Value::is_null) {
                *missing.entry(section).or_insert(0) += 1;
            }
        }
        if let Some(c) = s.get("contract").filter(|c| c.is_object()) {
            push("rounds", c.get("rounds").and_then(Value::as_f64));
            push("final_loss", c.get("final_loss").and_then(Value::as_f64));
            // The summary's own final held-out loss (gossip: the mean over honest robots), else
            // the last aggregation's.
            let heldout = f64s(c.get("heldout_loss_by_round"));
            push(
                "final_heldout_loss",
                c.get("final_heldout_loss")
                    .and_then(Value::as_f64)
                    .or_else(|| heldout.as_ref().and_then(|h| h.last().copied())),
            );
            let times = f64s(c.get("round_times_s"));
            if let (Some(t), Some(l)) = (&times, f64s(c.get("loss_by_round"))) {
                loss_runs.push((t.clone(), l));
            }
            if let (Some(t), Some(h)) = (times, heldout) {
                heldout_runs.push((t, h));
            }
            if let Some(sub) = c.get("submissions") {
                push("accepted", sub.get("accepted").and_then(Value::as_f64));
                push("outlier", sub.get("outlier").and_then(Value::as_f64));
            }
        }
        if let Some(t) = s.get("tokens").filter(|c| c.is_object()) {
            push(
                "honest_gain",
                t.get("honest_mean_gain").and_then(Value::as_f64),
            );
            push(
                "byzantine_gain",
                t.get("byzantine_mean_gain").and_then(Value::as_f64),
            );
            if let Some(c) = t.get("byzantine_control").filter(|c| c.is_object()) {
                push("control_time_s", c.get("time_s").and_then(Value::as_f64));
                push(
                    "control_heldout_loss",
                    c.get("heldout_loss").and_then(Value::as_f64),
                );
            }
        }
        if let Some(l) = s.get("ledger").filter(|c| c.is_object()) {
            push("height", l.get("canonical_height").and_then(Value::as_f64));
            push("forks", l.get("forks").and_then(Value::as_f64));
            if let Some(samples) = l.get("chain_bytes").and_then(Value::as_array) {
                let v: Vec<(f64, f64)> = samples
                    .iter()
                    .filter_map(|e| {
                        Some((e.get("time_s")?.as_f64()?, e.get("mean")?.as_f64()? / 1e6))
                    })
                    .collect();
                push("chain_mb", v.last().map(|&(_, mb)| mb));
                chain_runs.push(v);
            }
        }
        if let Some(a) = s.get("aggregation").filter(|a| a.is_object()) {
            let mb = |key: &str| a.get(key).and_then(Value::as_f64).map(|b| b / 1e6);
            push("sent_mb_per_robot", mb("bytes_sent_per_robot_mean"));
            push("stored_mb_per_robot", mb("bytes_stored_per_robot_mean"));
        }
        if let Some(w) = s.get("wall_s").and_then(Value::as_f64) {
            walls.push(w);
        }
    }
    let loss_fns: Vec<Box<dyn Fn(f64) -> Option<f64> + '_>> = loss_runs
        .iter()
        .map(|(t, l)| Box::new(move |at: f64| loss_at(t, l, at)) as Box<dyn Fn(f64) -> Option<f64>>)
        .collect();
    let heldout_fns: Vec<Box<dyn Fn(f64) -> Option<f64> + '_>> = heldout_runs
        .iter()
        .map(|(t, l)| Box::new(move |at: f64| loss_at(t, l, at)) as Box<dyn Fn(f64) -> Option<f64>>)
        .collect();
    let chain_fns: Vec<Box<dyn Fn(f64) -> Option<f64> + '_>> = chain_runs
        .iter()
        .map(|v| {
            Box::new(move |at: f64| v.iter().take_while(|(t, _)| *t <= at).last().map(|p| p.1))
                as Box<dyn Fn(f64) -> Option<f64>>
        })
        .collect();
    PointStats {
        point: name.to_string(),
        x,
        seeds: runs.iter().map(|r| r.seed).collect(),
        loss: curve(sim_time_s, &loss_fns),
        heldout: curve(sim_time_s, &heldout_fns),
        chain_mb: curve(sim_time_s, &chain_fns),
        metrics: metric_values
            .into_iter()
            .filter_map(|(k, v)| Stat::of(&v).map(|s| (k, s)))
            .collect(),
        wall_s: Stat::of(&walls),
        missing,
    }
}

/// Writes `numbers.csv` (scalar metrics) and `series.csv` (curves) as text: every deterministic
/// number of the report, with full precision.
pub fn numbers_csv(stats: &[ExperimentStats]) -> (String, String) {
    let ci = |s: &Stat| s.ci.map_or_else(String::new, |c| format!("{c:e}"));
    let mut numbers = String::from("experiment,point,x,n,metric,mean,ci95\n");
    let mut series = String::from("experiment,point,metric,time_s,n,mean,ci95\n");
    for e in stats {
        for p in &e.points {
            for (k, s) in &p.metrics {
                let _ = writeln!(
                    numbers,
                    "{},{},{},{},{},{:e},{}",
                    e.name,
                    p.point,
                    p.x,
                    s.n,
                    k,
                    s.mean,
                    ci(s)
                );
            }
            for (metric, c) in [
                ("loss", &p.loss),
                ("heldout_loss", &p.heldout),
                ("chain_mb", &p.chain_mb),
            ] {
                for (t, s) in c {
                    let _ = writeln!(
                        series,
                        "{},{},{},{},{},{:e},{}",
                        e.name,
                        p.point,
                        metric,
                        t,
                        s.n,
                        s.mean,
                        ci(s)
                    );
                }
            }
        }
    }
    (numbers, series)
}

/// Runs `swarmfl report`.
pub fn command(args: ReportArgs) -> anyhow::Result<ExitCode> {
    let path = report(&args.dir, &args.out)?;
    println!("wrote {}", path.display());
    Ok(ExitCode::SUCCESS)
}

/// Makes the report of the results in `dir` into `out`: figures (SVG and PNG), `report.md`,
/// `numbers.csv`, `series.csv` and `timing.csv`. Returns the path of `report.md`.
pub fn report(dir: &Path, out: &Path) -> anyhow::Result<PathBuf> {
    let (results, mut notes) = load(dir)?;
    anyhow::ensure!(
        !results.is_empty(),
        "no result files found under {} (expected <experiment>/<point>/seed<N>.json)",
        dir.display()
    );
    let stats = aggregate(&results);
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let (numbers, series) = numbers_csv(&stats);
    std::fs::write(out.join("numbers.csv"), numbers)?;
    std::fs::write(out.join("series.csv"), series)?;
    let mut timing = String::from("experiment,point,n,wall_s_mean,wall_s_ci95\n");
    for e in &stats {
        for p in &e.points {
            if let Some(w) = p.wall_s {
                let _ = writeln!(
                    timing,
                    "{},{},{},{},{}",
                    e.name,
                    p.point,
                    w.n,
                    w.mean,
                    w.ci.map_or_else(String::new, |c| c.to_string())
                );
            }
        }
    }
    std::fs::write(out.join("timing.csv"), timing)?;
    let mut figures = plots::draw_all(&stats, out, &mut notes)?;
    figures.extend(robustness::draw_all(&stats, out, &mut notes)?);
    figures.extend(defence::draw_all(&stats, out, &mut notes)?);
    if let Some(e) = stats.iter().find(|e| e.name == robustness::EXPERIMENT) {
        std::fs::write(out.join("e4-worst-case.csv"), robustness::worst_case(e).1)?;
    }
    let md = markdown(&stats, &figures, &notes, results.len());
    let path = out.join("report.md");
    std::fs::write(&path, md).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

/// One drawn figure: its file stem (`.svg` and `.png` exist) and caption, under an experiment.
#[derive(Clone, Debug)]
pub struct Figure {
    /// The experiment the figure belongs to.
    pub experiment: String,
    /// File stem inside the report directory.
    pub stem: String,
    /// What it shows.
    pub caption: String,
}

fn markdown(
    stats: &[ExperimentStats],
    figures: &[Figure],
    notes: &[String],
    files: usize,
) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# swarmfl report\n");
    let _ = writeln!(
        md,
        "{files} result files. Means over runs with 95 % Student-t confidence intervals \
         (`mean ± half-width`; none for a single run). Loss curves use {BIN_S} s bins. \
         All numbers at full precision: `numbers.csv`, `series.csv`; wall-clock times: \
         `timing.csv`.\n"
    );
    let get = |p: &PointStats, k: &str, digits: usize| {
        p.metrics
            .get(k)
            .map_or_else(|| "n/a".to_string(), |s| s.text(digits))
    };
    for e in stats {
        let _ = writeln!(md, "## {}\n", e.name);
        for f in figures.iter().filter(|f| f.experiment == e.name) {
            let _ = writeln!(
                md,
                "![{}]({}.png)\n\n*{}* ([SVG]({}.svg))\n",
                f.caption, f.stem, f.caption, f.stem
            );
        }
        if e.name == robustness::EXPERIMENT {
            let _ = writeln!(
                md,
                "Worst case: for each rule, the attack that leaves the highest final held-out \
                 loss at each Byzantine count, and that loss as a multiple of the rule's clean \
                 run (`e4-worst-case.csv`).\n\n{}",
                robustness::worst_case(e).0
            );
        }
        if e.name == defence::EXPERIMENT {
            let _ = writeln!(
                md,
                "When the Byzantine robots held more than `byzantine.switch_token_share` of the \
                 balances on the final chain (`tokens.byzantine_control`; `smart-then-collude` \
                 switches then):\n\n{}",
                defence::control_table(e)
            );
        }
        let _ = writeln!(
            md,
            "| point | {} | runs | rounds | final loss | final held-out loss | honest gain (tokens) | Byzantine gain (tokens) | chain MB | wall s/run |",
            e.axis
        );
        let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
        for p in &e.points {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                p.point,
                p.x,
                p.seeds.len(),
                get(p, "rounds", 1),
                get(p, "final_loss", 5),
                get(p, "final_heldout_loss", 5),
                get(p, "honest_gain", 2),
                get(p, "byzantine_gain", 2),
                get(p, "chain_mb", 2),
                p.wall_s.map_or_else(|| "n/a".to_string(), |s| s.text(1)),
            );
        }
        let mut missing: BTreeMap<&str, usize> = BTreeMap::new();
        for p in &e.points {
            for (k, n) in &p.missing {
                *missing.entry(k).or_default() += n;
            }
        }
        for (section, n) in missing {
            let _ = writeln!(
                md,
                "\nNote: {n} result files have no `{section}` section; the figures and columns that need it are skipped (n/a)."
            );
        }
        let _ = writeln!(md);
    }
    if !notes.is_empty() {
        let _ = writeln!(md, "## Notes\n");
        for n in notes {
            let _ = writeln!(md, "- {n}");
        }
    }
    md
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use swarmfl_core::rng::{self, Purpose};

    /// A synthetic summary that follows the schema of `summary.json` (`summary::RunSummary`) exactly, with values
    /// drawn from the seeded RNG. For tests only: not a result of any run.
    pub(crate) fn synthetic_summary(experiment: &str, x: f64, seed: u64) -> Value {
        let mut r = rng::stream(seed * 1000 + x as u64, Purpose::Dropout, 0);
        let sim_time_s = 5000.0;
        let byzantine = if experiment == "e1-expiration" {
            0
        } else {
            x as u32
        };
        let rounds = 40 + r.below(20) as usize;
        let mut t = 0.0;
        let mut loss = 0.3;
        let (mut times, mut losses, mut heldout) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..rounds {
            t += 60.0 + r.uniform() * 60.0;
            loss *= 0.9 + 0.05 * r.uniform() + 0.01 * f64::from(byzantine);
            times.push(t);
            losses.push(loss);
            heldout.push(loss * 1.2);
        }
        let chain: Vec<Value> = (1..=50)
            .map(|k| {
                let mean = f64::from(k) * 2.0e6 * (1.0 + 0.1 * r.uniform());
                serde_json::json!({"time_s": f64::from(k) * 100.0, "mean": mean, "max": mean * 1.05})
            })
            .collect();
        let robots: Vec<u32> = (0..byzantine).collect();
        serde_json::json!({
            "format": 1, "seed": seed, "preset": experiment, "config_hash": "00",
            "sim_time_s": sim_time_s, "robots": 15, "records": 1000, "final_hash": "ff",
            "wall_s": 10.0 + r.uniform(), "log_bytes": 12345,
            "world": {"collisions": 0, "mean_neighbours": 5.0, "samples_per_robot_per_600s": 20.0,
                      "samples_per_robot_per_600s_std": 1.0, "trajectories_discarded": 0},
            "byzantine": {"kind": if byzantine == 0 {"none"} else {"faulty"}, "count": byzantine, "robots": robots},
            "ledger": {"canonical_height": 498, "forks": 12, "reorgs": 30, "deepest_reorg": 2,
                       "tx_delay_median_s": 1.2, "tx_delay_p95_s": 8.0,
                       "bytes_per_submission": 16000.0, "chain_bytes": chain},
            "contract": {"rounds": rounds, "round_times_s": times, "loss_by_round": losses,
                         "heldout_loss_by_round": heldout, "final_loss": losses.last(),
                         "submissions": {"accepted": 700, "outlier": 10, "duplicate": 0,
                                         "insufficient_stake": 3, "malformed": 0}},
            "tokens": {"total_units_start": 315000000000u64, "total_units_end": 315000000000u64,
                       "honest_mean_gain": 1.5 + r.uniform(),
                       "byzantine_mean_gain": if byzantine == 0 { Value::Null } else { serde_json::json!(-4.0 + r.uniform()) },
                       "balances": vec![21.0; 15],
                       "byzantine_control": if byzantine >= 5 {
                           serde_json::json!({"height": 100, "time_s": 1000.0 + r.uniform(), "share": 0.6, "heldout_loss": 0.05})
                       } else { Value::Null }},
            "timing": {"world_s": 1.0, "learning_s": 30.0, "ledger_s": 2.0, "log_s": 0.3}
        })
    }

    /// Writes a synthetic sweep result directory: `runs` seeds per point of each experiment.
    pub(crate) fn synthetic_dir(dir: &Path, experiments: &[&str], runs: u64) {
        for name in experiments {
            let exp = experiments::experiment(name).unwrap();
            for p in &exp.points {
                for seed in 1..=runs {
                    let path = results::result_path(dir, name, &p.name, seed);
                    results::write_atomic(&path, &synthetic_summary(name, p.x, seed)).unwrap();
                }
            }
        }
    }

    fn temp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("swarmfl-report-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn stats_match_hand_computed_values() {
        let check = |values: &[f64], mean: f64, ci: Option<f64>| {
            let s = Stat::of(values).unwrap();
            assert!((s.mean - mean).abs() < 1e-12, "{values:?}");
            match (s.ci, ci) {
                (Some(a), Some(b)) => assert!((a - b).abs() < 1e-9, "{values:?}: {a} vs {b}"),
                (a, b) => assert_eq!(a, b),
            }
        };
        check(&[2.0], 2.0, None);
        // n = 2: sd = sqrt(2), half-width = 12.706 * sqrt(2) / sqrt(2).
        check(&[1.0, 3.0], 2.0, Some(12.706));
        // n = 4: sd = sqrt(5/3), t(3) = 3.182.
        check(
            &[1.0, 2.0, 3.0, 4.0],
            2.5,
            Some(3.182 * (5.0f64 / 3.0).sqrt() / 2.0),
        );
        assert!(Stat::of(&[]).is_none());
        assert_eq!(t_975(30), 2.042);
        assert_eq!(t_975(120), 1.980);
        assert!(t_975(45) < 2.021 && t_975(45) > 2.000);
        assert!(t_975(100_000) > 1.960 && t_975(100_000) < 1.961);
    }

    #[test]
    fn loss_at_a_time_is_the_last_closed_round() {
        let times = [50.0, 120.0, 300.0];
        let losses = [0.5, 0.25, 0.125];
        let check = |t: f64, expect: Option<f64>| {
            assert_eq!(loss_at(&times, &losses, t), expect, "t = {t}")
        };
        check(10.0, None);
        check(50.0, Some(0.5));
        check(119.0, Some(0.5));
        check(200.0, Some(0.25));
        check(5000.0, Some(0.125));
    }

    #[test]
    fn report_numbers_do_not_depend_on_file_order_or_sharding() {
        let dir = temp("order");
        synthetic_dir(&dir, &["e1-expiration", "e2-faulty"], 3);
        let (results, notes) = load(&dir).unwrap();
        assert!(notes.is_empty(), "{notes:?}");
        assert_eq!(results.len(), (5 + 8) * 3);
        let reference = numbers_csv(&aggregate(&results));
        // Any other order of the same results gives the same numbers once sorted.
        let mut shuffled = results.clone();
        shuffled.reverse();
        shuffled.rotate_left(7);
        sort(&mut shuffled);
        assert_eq!(numbers_csv(&aggregate(&shuffled)), reference);
        // Three shards (`--shard I/3`: the tasks with index % 3 == I) write their shares into
        // separate directories; merged they are the same.
        let merged = temp("merged");
        for index in 0..3 {
            for name in ["e1-expiration", "e2-faulty"] {
                let exp = experiments::experiment(name).unwrap();
                for t in experiments::tasks(&exp, 3, &[])
                    .iter()
                    .filter(|t| t.index % 3 == index)
                {
                    let from = results::result_path(&dir, name, &t.point, t.seed);
                    let to = results::result_path(&merged, name, &t.point, t.seed);
                    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
                    std::fs::copy(from, to).unwrap();
                }
            }
        }
        let (merged_results, _) = load(&merged).unwrap();
        assert_eq!(numbers_csv(&aggregate(&merged_results)), reference);
        let (numbers, series) = &reference;
        assert!(numbers.contains("e2-faulty,byzantine-7,7,3,byzantine_gain,"));
        assert!(
            series
                .lines()
                .filter(|l| l.starts_with("e1-expiration,expiration-250,loss,"))
                .count()
                == 50
        );
        std::fs::remove_dir_all(&dir).unwrap();
        std::fs::remove_dir_all(&merged).unwrap();
    }

    #[test]
    fn aggregation_follows_the_definition() {
        // Two runs by hand: loss at t = 100 is the mean of the last closed rounds.
        let mk = |seed: u64, times: Vec<f64>, losses: Vec<f64>, gain: f64| {
            let mut s = synthetic_summary("e2-faulty", 2.0, seed);
            s["sim_time_s"] = serde_json::json!(300.0);
            s["contract"]["round_times_s"] = serde_json::json!(times);
            s["contract"]["final_loss"] = serde_json::json!(losses.last());
            s["contract"]["loss_by_round"] = serde_json::json!(losses);
            s["tokens"]["honest_mean_gain"] = serde_json::json!(gain);
            RunResult {
                experiment: "e2-faulty".into(),
                point: "byzantine-2".into(),
                seed,
                summary: s,
            }
        };
        let results = vec![
            mk(1, vec![50.0, 150.0], vec![0.4, 0.2], 1.0),
            mk(2, vec![120.0, 250.0], vec![0.6, 0.1], 3.0),
        ];
        let stats = aggregate(&results);
        let p = &stats[0].points[0];
        assert_eq!(p.x, 2.0);
        let loss: Vec<(f64, usize, f64)> = p.loss.iter().map(|(t, s)| (*t, s.n, s.mean)).collect();
        assert_eq!(
            loss,
            vec![
                (100.0, 1, 0.4),
                (200.0, 2, 0.4),
                (300.0, 2, 0.15000000000000002)
            ]
        );
        let gain = p.metrics["honest_gain"];
        assert_eq!((gain.n, gain.mean), (2, 2.0));
        assert_eq!(p.metrics["final_loss"].mean, 0.15000000000000002);
    }

    #[test]
    fn summaries_without_the_learning_sections_are_tolerated() {
        let dir = temp("partial");
        let path = results::result_path(&dir, "e1-faulty", "faulty-1", 1);
        let mut s = synthetic_summary("e1-faulty", 1.0, 1);
        let map = s.as_object_mut().unwrap();
        for k in ["contract", "tokens", "ledger", "byzantine", "timing"] {
            map.remove(k);
        }
        results::write_atomic(&path, &s).unwrap();
        let out = dir.join("report");
        let md_path = report(&dir, &out).unwrap();
        let md = std::fs::read_to_string(md_path).unwrap();
        assert!(md.contains("have no `contract` section"), "{md}");
        assert!(md.contains("| faulty-1 | 1 | 1 | n/a |"), "{md}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn damaged_and_mixed_results_are_refused_naming_the_files() {
        let dir = temp("refused");
        synthetic_dir(&dir, &["e2-faulty"], 2);
        let broken = dir.join("e2-faulty/byzantine-3/seed2.json");
        std::fs::write(&broken, "{\"seed\": 2, \"contr").unwrap();
        let wrong = dir.join("e2-faulty/byzantine-1/seed1.json");
        std::fs::write(&wrong, "{\"seed\": 9}").unwrap();
        let err = report(&dir, &dir.join("report")).unwrap_err().to_string();
        assert!(err.contains("2 result file(s)"), "{err}");
        assert!(
            err.contains("byzantine-3/seed2.json: not readable as JSON"),
            "{err}"
        );
        assert!(err.contains("byzantine-1/seed1.json: a JSON file"), "{err}");
        assert!(!dir.join("report/report.md").exists());
        synthetic_dir(&dir, &["e2-faulty"], 2);
        // seed 3 of one point made at another duration: refused, both settings named.
        let mut other = synthetic_summary("e2-faulty", 2.0, 3);
        other["config_hash"] = "1234567890abcdef".into();
        other["sweep"] =
            serde_json::json!({"overrides": ["byzantine.count=2", "run.duration_s=200"]});
        results::write_atomic(
            &results::result_path(&dir, "e2-faulty", "byzantine-2", 3),
            &other,
        )
        .unwrap();
        let err = report(&dir, &dir.join("report")).unwrap_err().to_string();
        assert!(err.contains("e2-faulty byzantine-2 mixes results"), "{err}");
        assert!(
            err.contains("seed1.json was made with no --set (configuration 00)"),
            "{err}"
        );
        assert!(
            err.contains("seed3.json with --set run.duration_s=200 (configuration 1234567890ab)"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_full_synthetic_report_draws_every_figure() {
        let dir = temp("full");
        synthetic_dir(&dir, &EXPERIMENTS, 3);
        let out = dir.join("report");
        let md = std::fs::read_to_string(report(&dir, &out).unwrap()).unwrap();
        for stem in [
            "e1-expiration-loss",
            "e1-faulty-loss",
            "e2-faulty-loss",
            "e2-faulty-tokens",
            "e2-malicious-tokens",
            "e3-smart-loss",
            "e3-smart-tokens",
            "e2-faulty-chain",
            "e5-smart-defence-smart-tokens",
            "e5-smart-defence-smart-heldout",
            "e5-smart-defence-switch-tokens",
            "e5-smart-defence-switch-heldout",
        ] {
            for ext in ["svg", "png"] {
                let f = out.join(format!("{stem}.{ext}"));
                let len = std::fs::metadata(&f).map(|m| m.len()).unwrap_or(0);
                assert!(len > 1000, "{} is missing or empty", f.display());
            }
            assert!(
                md.contains(&format!("({stem}.png)")),
                "{stem} is not in report.md"
            );
        }
        assert!(
            md.contains("| agreement--smart-then-collude--7 | 3 | 3 | 10"),
            "the control table of e5"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! The statistics of a report: per experiment and configuration point, means and 95 %
//! confidence intervals over runs, of scalar metrics and of curves over time.
//!
//! For `n` runs with mean `m` and sample standard deviation `s`, the 95 % interval is
//! `m +- t(0.975, n-1) * s / sqrt(n)` (Student t; no interval for `n < 2`). Curves over time
//! use [`BIN_S`] bins: the loss of a run at time `t` is the `loss_by_round` entry of the last
//! round whose `round_times_s` is at or before `t` (a run with no round yet does not count in
//! that bin); chain size at `t` is the last `ledger.chain_bytes` sample at or before `t`.

use std::collections::BTreeMap;

use swarmfl_core::metrics::{ContractSummary, TokenSummary};
use swarmfl_core::summary::LedgerSummary;

use super::coords::GridCoords;
use super::load::RunResult;
use crate::experiments;
use crate::summary::{count, Summary};

/// Width of the time bins of the curves, in simulated seconds.
pub const BIN_S: f64 = 100.0;

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

    /// `mean +- ci` as text ([`fixed`]: never `-0.00`).
    pub fn text(self, digits: usize) -> String {
        match self.ci {
            Some(ci) => format!("{} ± {}", fixed(self.mean, digits), fixed(ci, digits)),
            None => fixed(self.mean, digits),
        }
    }
}

/// `v` with `digits` decimals, as tables show numbers: a value that rounds to zero is `0.00`,
/// never `-0.00` (a tiny negative mean, or IEEE's negative zero).
pub fn fixed(v: f64, digits: usize) -> String {
    let text = format!("{v:.digits$}");
    match text.strip_prefix('-') {
        Some(unsigned) if unsigned.chars().all(|c| c == '0' || c == '.') => unsigned.to_string(),
        _ => text,
    }
}

/// The 95 % Wilson score interval of a proportion: `k` successes of `n` trials, as
/// `(low, high)` fractions; `(0, 1)` for no trials. Unlike `k/n +- 1.96 se` it stays inside
/// [0, 1] and is not empty at 0 of n or n of n.
pub fn wilson(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (k, n) = (k as f64, n as f64);
    let z = 1.959_963_984_540_054;
    let p = k / n;
    let z2n = z * z / n;
    let centre = p + z2n / 2.0;
    let half = z * (p * (1.0 - p) / n + z2n / (4.0 * n)).sqrt();
    let low = ((centre - half) / (1.0 + z2n)).max(0.0);
    let high = ((centre + half) / (1.0 + z2n)).min(1.0);
    (low, high)
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
    /// Every override of the point's first run (`sweep.overrides`: the point's, then the
    /// sweep's `--set`); one point holds one configuration (`load` checks it).
    pub overrides: Vec<String>,
    /// The simulated duration of its runs in seconds (`sim_time_s`, the longest).
    pub duration_s: Option<f64>,
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
    /// Results lacking a section the report uses, by section name. Always empty since the
    /// results are read typed: a result file without a section is refused when read.
    pub missing: BTreeMap<&'static str, usize>,
}

/// Everything computed for one experiment.
#[derive(Clone, Debug)]
pub struct ExperimentStats {
    /// The experiment's id.
    pub name: String,
    /// The grid's axis label (a `--grid` sweep's: its first key; its figures and tables use
    /// `grid`).
    pub axis: String,
    /// The preset its points start from (`sweep.preset`, else the experiment's name).
    pub preset: String,
    /// Per point, in grid order.
    pub points: Vec<PointStats>,
    /// A `sweep --grid` experiment's keys and its points' values on them (`None` for a
    /// built-in experiment).
    pub grid: Option<GridCoords>,
}

/// The loss of a run at time `t`: the last round closed at or before `t`.
pub(super) fn loss_at(times: &[f64], losses: &[f64], t: f64) -> Option<f64> {
    let closed = times.iter().take_while(|&&rt| rt <= t).count();
    closed
        .checked_sub(1)
        .and_then(|r| losses.get(r).copied())
        .filter(|v| v.is_finite())
}

/// A series of numbers, None if any entry is not finite (JSON holds those as `null`, and a
/// series with a gap is left out as it was when the reports read the JSON itself).
fn finite(v: &[f64]) -> Option<Vec<f64>> {
    v.iter().all(|x| x.is_finite()).then(|| v.to_vec())
}

/// A count as the metrics hold it.
fn number(n: Option<u64>) -> Option<f64> {
    n.map(|n| n as f64)
}

/// The curve over [`BIN_S`] bins of `per_run` values at each bin's end (runs without a value
/// there do not count).
pub(super) fn curve(sim_time_s: f64, per_run: &[Box<dyn Fn(f64) -> Option<f64> + '_>]) -> Curve {
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
            let sweep = &r.result.sweep;
            let grid_axis = sweep
                .overrides
                .first()
                .map(|o| o.split_once('=').map_or(o.as_str(), |(k, _)| k).to_string());
            out.push(ExperimentStats {
                name: r.experiment.clone(),
                preset: sweep.preset.clone(),
                axis: exp.map_or_else(
                    || grid_axis.unwrap_or_else(|| "point".to_string()),
                    |e| e.axis.to_string(),
                ),
                points: Vec::new(),
                grid: None,
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
            // A built-in experiment's x is its grid's; a --grid point's is in its files.
            let x = grid
                .as_ref()
                .and_then(|g| g.points.iter().find(|p| p.name == name))
                .map(|p| p.x)
                .or_else(|| runs_x(&mine, name))
                .unwrap_or(f64::NAN);
            exp.points.push(point_stats(name, x, &runs));
        }
        if grid.is_none() {
            exp.grid = grid_coords(&exp.points);
        }
    }
    out
}

/// The x a `--grid` sweep recorded for a point (`sweep.x` of its first file).
fn runs_x(results: &[&RunResult], point: &str) -> Option<f64> {
    results
        .iter()
        .find(|r| r.point == point)
        .and_then(|r| r.result.sweep.x)
}

/// The scalar metrics of one run's summary by name (what `numbers.csv` averages), and its
/// wall-clock seconds.
pub fn run_metrics(summary: &Summary) -> (BTreeMap<&'static str, f64>, Option<f64>) {
    let mut g = Gathered::default();
    g.run(summary);
    let metrics = g
        .metric_values
        .into_iter()
        .filter_map(|(k, v)| v.first().map(|&x| (k, x)))
        .collect();
    (metrics, g.walls.first().copied())
}

/// The statistics of one point from its runs (in seed order).
fn point_stats(name: &str, x: f64, runs: &[&RunResult]) -> PointStats {
    let sim_time_s = runs
        .iter()
        .map(|r| r.result.summary.run.sim_time_s)
        .fold(0.0f64, f64::max);
    let mut g = Gathered::default();
    for r in runs {
        g.run(&r.result.summary);
    }
    let loss_fns: Vec<Box<dyn Fn(f64) -> Option<f64> + '_>> = g
        .loss_runs
        .iter()
        .map(|(t, l)| Box::new(move |at: f64| loss_at(t, l, at)) as Box<dyn Fn(f64) -> Option<f64>>)
        .collect();
    let heldout_fns: Vec<Box<dyn Fn(f64) -> Option<f64> + '_>> = g
        .heldout_runs
        .iter()
        .map(|(t, l)| Box::new(move |at: f64| loss_at(t, l, at)) as Box<dyn Fn(f64) -> Option<f64>>)
        .collect();
    let chain_fns: Vec<Box<dyn Fn(f64) -> Option<f64> + '_>> = g
        .chain_runs
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
        overrides: runs
            .first()
            .map_or_else(Vec::new, |r| r.result.sweep.overrides.clone()),
        duration_s: (sim_time_s > 0.0).then_some(sim_time_s),
        loss: curve(sim_time_s, &loss_fns),
        heldout: curve(sim_time_s, &heldout_fns),
        chain_mb: curve(sim_time_s, &chain_fns),
        metrics: g
            .metric_values
            .into_iter()
            .filter_map(|(k, v)| Stat::of(&v).map(|s| (k, s)))
            .collect(),
        wall_s: Stat::of(&g.walls),
        missing: BTreeMap::new(),
    }
}

/// The values of a point's runs, gathered run by run (so each list is in seed order), before
/// any statistic.
#[derive(Default)]
struct Gathered {
    /// Scalar metrics by name, one value per run that has it.
    metric_values: BTreeMap<&'static str, Vec<f64>>,
    /// Per run: round close times and the loss of each round.
    loss_runs: Vec<(Vec<f64>, Vec<f64>)>,
    /// Per run: round close times and the held-out loss of each round's model.
    heldout_runs: Vec<(Vec<f64>, Vec<f64>)>,
    /// Per run: (time, mean chain MB) samples.
    chain_runs: Vec<Vec<(f64, f64)>>,
    /// Wall-clock seconds per run.
    walls: Vec<f64>,
}

impl Gathered {
    /// Adds a finite value of metric `key`.
    fn push(&mut self, key: &'static str, v: Option<f64>) {
        if let Some(v) = v.filter(|v| v.is_finite()) {
            self.metric_values.entry(key).or_default().push(v);
        }
    }

    /// Adds one run's summary.
    fn run(&mut self, s: &Summary) {
        self.contract(&s.run.contract);
        self.tokens(&s.run.tokens);
        self.ledger(&s.run.ledger);
        let a = &s.run.aggregation;
        self.push("sent_mb_per_robot", Some(a.bytes_sent_per_robot_mean / 1e6));
        self.push(
            "stored_mb_per_robot",
            Some(a.bytes_stored_per_robot_mean / 1e6),
        );
        if !s.wall_s.is_nan() {
            self.walls.push(s.wall_s);
        }
    }

    /// The `contract` section: rounds, losses and submissions.
    fn contract(&mut self, c: &ContractSummary) {
        self.push("rounds", number(Some(c.rounds)));
        self.push("final_loss", c.final_loss);
        // The summary's own final held-out loss (gossip: the mean over honest robots), else
        // the last aggregation's.
        let heldout = finite(&c.heldout_loss_by_round);
        self.push(
            "final_heldout_loss",
            c.final_heldout_loss
                .or_else(|| heldout.as_ref().and_then(|h| h.last().copied())),
        );
        let times = finite(&c.round_times_s);
        if let (Some(t), Some(l)) = (&times, finite(&c.loss_by_round)) {
            self.loss_runs.push((t.clone(), l));
        }
        if let (Some(t), Some(h)) = (times, heldout) {
            self.heldout_runs.push((t, h));
        }
        // The round majorities (RESEARCH.md): summaries made before the field lack it.
        if let (Some(n), true) = (c.byzantine_majority_rounds, c.rounds > 0) {
            self.push("byzantine_majority_rate", Some(n as f64 / c.rounds as f64));
        }
        self.push("accepted", number(count(&c.submissions, "accepted")));
        self.push("outlier", number(count(&c.submissions, "outlier")));
    }

    /// The `tokens` section: gains and when the Byzantine robots took control.
    fn tokens(&mut self, t: &TokenSummary) {
        self.push("honest_gain", t.honest_mean_gain);
        self.push("byzantine_gain", t.byzantine_mean_gain);
        if let Some(c) = &t.byzantine_control {
            self.push("control_time_s", Some(c.time_s));
            self.push("control_heldout_loss", Some(c.heldout_loss));
        }
    }

    /// The `ledger` section: height, forks and the chain size over time.
    fn ledger(&mut self, l: &LedgerSummary) {
        self.push("height", number(Some(l.canonical_height)));
        self.push("forks", number(Some(l.forks)));
        let v: Vec<(f64, f64)> = l
            .chain_bytes
            .iter()
            .map(|e| (e.time_s, e.mean / 1e6))
            .collect();
        self.push("chain_mb", v.last().map(|&(_, mb)| mb));
        self.chain_runs.push(v);
    }
}

/// The grid coordinates of an experiment's points ([`GridCoords::of`] over their names and
/// recorded overrides); `None` when no point is a `--grid` point.
pub fn grid_coords(points: &[PointStats]) -> Option<GridCoords> {
    GridCoords::of(
        points
            .iter()
            .map(|p| (p.point.as_str(), p.overrides.as_slice())),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Wilson intervals against published values (Newcombe 1998, table I: 0/10, 5/10 and
    /// 10/10 at 95 %).
    #[test]
    fn wilson_intervals_match_published_values() {
        let close = |(lo, hi): (f64, f64), want: (f64, f64)| {
            assert!(
                (lo - want.0).abs() < 5e-5 && (hi - want.1).abs() < 5e-5,
                "{lo} {hi}"
            );
        };
        close(wilson(0, 10), (0.0, 0.2775));
        close(wilson(5, 10), (0.2366, 0.7634));
        close(wilson(10, 10), (0.7225, 1.0));
        close(wilson(81, 263), (0.2553, 0.3662));
        assert_eq!(wilson(0, 0), (0.0, 1.0));
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
    fn a_number_that_rounds_to_zero_prints_as_zero_not_minus_zero() {
        assert_eq!(fixed(-0.0, 4), "0.0000");
        assert_eq!(fixed(-0.00001, 4), "0.0000");
        assert_eq!(fixed(-0.00005001, 4), "-0.0001");
        assert_eq!(fixed(-2.5, 2), "-2.50");
        assert_eq!(fixed(-0.4, 0), "0");
        let tiny = Stat {
            n: 2,
            mean: -0.001,
            ci: Some(-0.0),
        };
        assert_eq!(tiny.text(2), "0.00 ± 0.00");
        let one = Stat {
            n: 1,
            mean: -1e-9,
            ci: None,
        };
        assert_eq!(one.text(4), "0.0000");
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
}

//! `e6-scale` and `e6-scale-1000` (issue 32): the paper's rounds, the buffered protocol and the
//! gossip baseline at 15 to 1000 robots. Per swarm size, the held-out loss over time of each
//! protocol; versus the size, the final held-out loss, the model versions, the bytes a node
//! sends and stores, and the wall time of a run; and one table of every point, with the
//! 240-robot points with faulty robots set against their protocol's clean run of that size.
//!
//! Every number is read from one run's `summary.json` ([`RunNumbers`]), then summarised over
//! the point's runs. The table gives mean ± sample standard deviation: with two or three seeds a
//! 95 % interval (t = 12.7 at two) is wider than the spread it describes. The figures and
//! `numbers.csv` keep the report's 95 % intervals: [`extend`] adds the study's numbers to its
//! points' metrics and starts their held-out curves at the genesis model, so a protocol that
//! makes no version by a time shows the loss the swarm then holds instead of no value.

use std::fmt::Write as _;
use std::path::Path;

use swarmfl_core::config::ByzantineKind;

use super::load::RunResult;
use super::plots::{self, draw_planned, note_textless, Figure, Kind, Plot, Series};
use super::stats::{self, fixed, ExperimentStats, PointStats, Stat};
use super::study::{Drawn, Section, StudyReport};
use crate::experiments::{self, DrawnBy, Entry, E6_PROTOCOLS};
use crate::summary::{count, Summary};

/// The study report of the experiments drawn by [`DrawnBy::Scale`] (the sizes with three
/// seeds, and 1000 robots with two): one study, its figures and tables in the section of the
/// first of them in the results.
#[derive(Debug)]
pub struct Scale;

impl StudyReport for Scale {
    fn draws(&self, entry: Option<&Entry>) -> bool {
        entry.is_some_and(|e| e.drawn_by == DrawnBy::Scale)
    }

    fn extend(&self, results: &[RunResult], stats: &mut [ExperimentStats]) {
        extend(stats, &study(results));
    }

    fn draw(
        &self,
        results: &[RunResult],
        stats: &[ExperimentStats],
        out: &Path,
        notes: &mut Vec<String>,
    ) -> anyhow::Result<Drawn> {
        let rows = study(results);
        let mut drawn = Drawn {
            figures: draw_all(stats, &rows, out, notes)?,
            ..Drawn::default()
        };
        if let Some(home) = home(&rows) {
            drawn.sections.push(Section {
                experiment: home.to_string(),
                text: section(&rows),
            });
        }
        Ok(drawn)
    }
}

/// The names of the experiments of the study, in the sweep's order.
fn experiments() -> Vec<&'static str> {
    experiments::ALL
        .iter()
        .filter(|e| Scale.draws(Some(e)))
        .map(Entry::name)
        .collect()
}

/// Submission outcomes with a column of their own; every other outcome is a refusal.
const OWN_COLUMNS: [&str; 4] = ["accepted", "aggregated", "outlier", "stale"];

/// What one run measured, read from its summary (`None`: the summary lacks it).
#[derive(Clone, Debug, PartialEq)]
pub struct RunNumbers {
    /// The seed.
    pub seed: u64,
    /// Held-out loss of the shared model at the end (`final_heldout_loss`, else the last
    /// version's); the genesis model's when no version was made (gossip: the mean over honest
    /// robots of their own models').
    pub heldout: Option<f64>,
    /// The genesis model's held-out loss (the arena's size sets it: targets are in world
    /// metres, so losses of different sizes compare through it).
    pub genesis: Option<f64>,
    /// Model versions made (`contract.rounds`: rounds closed, buffers aggregated; gossip:
    /// merges of honest robots).
    pub versions: Option<f64>,
    /// Submissions accepted, the one that closed a round or buffer included.
    pub accepted: Option<f64>,
    /// Submissions rejected as outliers.
    pub outlier: Option<f64>,
    /// Submissions refused as stale (a base more than `contract.max_staleness` behind).
    pub stale: Option<f64>,
    /// Every other refusal (unknown, future or duplicate base, duplicate, stake, malformed).
    pub refused: Option<f64>,
    /// Models in the aggregations, honest and Byzantine.
    pub aggregated: Option<f64>,
    /// Byzantine (here faulty) models in the aggregations.
    pub faulty_aggregated: Option<f64>,
    /// Mean token change of the Byzantine robots (`tokens.byzantine_mean_gain`).
    pub faulty_gain: Option<f64>,
    /// MB a node sent for aggregation (lost ones included), mean over nodes.
    pub sent_mb: Option<f64>,
    /// MB a node stores for aggregation at the end, mean over nodes.
    pub stored_mb: Option<f64>,
    /// Wall-clock seconds of the run.
    pub wall_s: Option<f64>,
    /// The held-out loss over time: the genesis model's at 0 s (when the summary has it), then
    /// each version's.
    pub heldout_times_s: Vec<f64>,
    /// The losses of [`RunNumbers::heldout_times_s`].
    pub heldout_losses: Vec<f64>,
    /// The median held-out loss over the last 1000 s
    /// (`contract.median_heldout_loss_last_1000s`; absent in summaries made before it).
    pub median_last: Option<f64>,
    /// Accepted updates by their base's age in versions (buffered and matched; empty
    /// otherwise).
    pub age_versions: Vec<u64>,
    /// Median and 95th percentile of the base's age in seconds.
    pub age_s: Option<(f64, f64)>,
    /// Median and 95th percentile of a new version's delay to reach a node's head.
    pub propagation_s: Option<(f64, f64)>,
}

impl RunNumbers {
    /// The numbers of `summary`, the result of `seed`. JSON holds NaN as `null`, which the
    /// table shows as missing: a NaN number counts as absent, a series with one as none.
    pub fn of(seed: u64, summary: &Summary) -> RunNumbers {
        let run = &summary.run;
        let contract = &run.contract;
        let present = |x: f64| (!x.is_nan()).then_some(x);
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite()).then(|| v.to_vec());
        let initial = present(contract.heldout_loss_initial);
        let submissions = &contract.submissions;
        // Folded from +0: `sum` of no values is -0, which the table would print as "-0.0".
        let outcomes = |names: &[&str]| {
            Some(
                names
                    .iter()
                    .filter_map(|n| count(submissions, n))
                    .fold(0.0, |a, b| a + b as f64),
            )
        };
        let refused = Some(
            submissions
                .iter()
                .filter(|(k, _)| !OWN_COLUMNS.contains(&k.as_str()))
                .fold(0.0, |a, (_, &b)| a + b as f64),
        );
        let honest = contract.aggregated_honest as f64;
        let faulty = contract.aggregated_byzantine as f64;
        let aggregation = &run.aggregation;
        let mb = |bytes: f64| present(bytes).map(|b| b / 1e6);
        let by_version = finite(&contract.heldout_loss_by_round).unwrap_or_default();
        // A summary without the genesis model's loss has its versions' alone.
        let (mut heldout_times_s, mut heldout_losses) = (Vec::new(), Vec::new());
        if let (Some(times), Some(losses)) = (
            finite(&contract.round_times_s),
            finite(&contract.heldout_loss_by_round),
        ) {
            if let Some(first) = initial {
                heldout_times_s.push(0.0);
                heldout_losses.push(first);
            }
            heldout_times_s.extend(times);
            heldout_losses.extend(losses);
        }
        let is_byzantine = run.byzantine.kind != ByzantineKind::None;
        RunNumbers {
            seed,
            heldout: contract
                .final_heldout_loss
                .or_else(|| by_version.last().copied())
                .or(initial),
            genesis: initial,
            versions: Some(contract.rounds as f64),
            accepted: outcomes(&["accepted", "aggregated"]),
            outlier: outcomes(&["outlier"]),
            stale: outcomes(&["stale"]),
            refused,
            aggregated: Some(honest + faulty),
            faulty_aggregated: Some(faulty).filter(|_| is_byzantine),
            faulty_gain: run.tokens.byzantine_mean_gain,
            sent_mb: mb(aggregation.bytes_sent_per_robot_mean),
            stored_mb: mb(aggregation.bytes_stored_per_robot_mean),
            wall_s: present(summary.wall_s),
            heldout_times_s,
            heldout_losses,
            median_last: contract.median_heldout_loss_last_1000s.and_then(present),
            age_versions: contract
                .staleness
                .as_ref()
                .map(|a| a.age_versions.clone())
                .unwrap_or_default(),
            age_s: contract
                .staleness
                .as_ref()
                .filter(|a| a.age_s.count > 0)
                .map(|a| (a.age_s.median_s, a.age_s.p95_s)),
            propagation_s: run
                .ledger
                .details
                .version_propagation
                .as_ref()
                .filter(|p| p.delay.count > 0)
                .map(|p| (p.delay.median_s, p.delay.p95_s)),
        }
    }
}

/// One point of the study and its runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The experiment (`e6-scale` or `e6-scale-1000`).
    pub experiment: String,
    /// The point's name (`<protocol>-<robots>`, `<protocol>-240-faulty-24`).
    pub point: String,
    /// `rounds`, `buffered` or `gossip` (the point's `protocol` tag).
    pub protocol: String,
    /// The swarm's size (the point's x).
    pub robots: f64,
    /// Faulty robots (0 for a clean point).
    pub faulty: u32,
    /// Its runs, in seed order.
    pub runs: Vec<RunNumbers>,
    /// Points with faulty robots: per seed that the clean point of the same protocol and size
    /// also has, the final held-out loss divided by the clean run's (seed order).
    pub ratio_to_clean: Vec<f64>,
}

impl RunNumbers {
    /// The final held-out loss as a fraction of the genesis model's.
    pub fn of_genesis(&self) -> Option<f64> {
        let fraction = self.heldout? / self.genesis?;
        fraction.is_finite().then_some(fraction)
    }

    /// The median held-out loss over the last 1000 s as a fraction of the genesis model's.
    pub fn median_of_genesis(&self) -> Option<f64> {
        let fraction = self.median_last? / self.genesis?;
        fraction.is_finite().then_some(fraction)
    }

    /// The share of accepted updates whose base was at most `versions` behind.
    fn age_share_within(&self, versions: usize) -> Option<f64> {
        let total: u64 = self.age_versions.iter().sum();
        let within: u64 = self.age_versions.iter().take(versions + 1).sum();
        (total > 0).then(|| within as f64 / total as f64)
    }
}

impl Row {
    /// The spread over the runs of what `f` reads (runs without it do not count).
    pub fn spread(&self, f: impl Fn(&RunNumbers) -> Option<f64>) -> Option<Spread> {
        Spread::of(&self.runs.iter().filter_map(f).collect::<Vec<_>>())
    }

    /// The 95 % statistic of the same, for the figures and `numbers.csv`.
    fn stat(&self, f: impl Fn(&RunNumbers) -> Option<f64>) -> Option<Stat> {
        Stat::of(&self.runs.iter().filter_map(f).collect::<Vec<_>>())
    }
}

/// A mean with the sample standard deviation of `n` values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// Number of values.
    pub n: usize,
    /// Their mean.
    pub mean: f64,
    /// Their sample standard deviation (None for a single value).
    pub sd: Option<f64>,
}

impl Spread {
    /// The spread of `values` (None without any); sums run in the order given.
    pub fn of(values: &[f64]) -> Option<Spread> {
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let sd = (n >= 2).then(|| {
            let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64;
            var.sqrt()
        });
        Some(Spread { n, mean, sd })
    }

    /// `mean ± sd` as text (the mean alone for one value).
    pub fn text(self, digits: usize) -> String {
        match self.sd {
            Some(sd) => format!("{} ± {}", fixed(self.mean, digits), fixed(sd, digits)),
            None => fixed(self.mean, digits),
        }
    }
}

/// `spread` as text, `n/a` without values.
fn text(spread: Option<Spread>, digits: usize) -> String {
    spread.map_or_else(|| "n/a".to_string(), |s| s.text(digits))
}

/// The study's points from sorted results (grid order), with each faulty point's ratios to its
/// clean point.
pub fn study(results: &[RunResult]) -> Vec<Row> {
    let mut rows: Vec<Row> = Vec::new();
    for r in results
        .iter()
        .filter(|r| Scale.draws(experiments::entry(&r.experiment)))
    {
        let same = |row: &Row| row.experiment == r.experiment && row.point == r.point;
        if !rows.last().is_some_and(same) {
            rows.push(new_row(r));
        }
        if let Some(row) = rows.last_mut() {
            row.runs.push(RunNumbers::of(r.seed, &r.result.summary));
        }
    }
    let ratios: Vec<Vec<f64>> = rows.iter().map(|row| ratios_to_clean(row, &rows)).collect();
    for (row, ratio) in rows.iter_mut().zip(ratios) {
        row.ratio_to_clean = ratio;
    }
    rows
}

/// An empty row for `r`'s point: its protocol and size from the grid (else from the point's
/// name and the summary), its faulty robots from the summary.
fn new_row(r: &RunResult) -> Row {
    let point = experiments::experiment(&r.experiment)
        .ok()
        .and_then(|e| e.points.into_iter().find(|p| p.name == r.point));
    let protocol = point
        .as_ref()
        .and_then(|p| p.tag("protocol"))
        .unwrap_or_else(|| r.point.split('-').next().unwrap_or("").to_string());
    let robots = point
        .as_ref()
        .map(|p| p.x)
        .unwrap_or(f64::from(r.result.summary.run.robots));
    let byzantine = &r.result.summary.run.byzantine;
    let faulty = if byzantine.kind != ByzantineKind::None {
        byzantine.count
    } else {
        0
    };
    Row {
        experiment: r.experiment.clone(),
        point: r.point.clone(),
        protocol,
        robots,
        faulty,
        runs: Vec::new(),
        ratio_to_clean: Vec::new(),
    }
}

/// The clean point of `row`'s protocol and size in its experiment.
fn clean_of<'a>(row: &Row, rows: &'a [Row]) -> Option<&'a Row> {
    rows.iter().find(|c| {
        c.faulty == 0
            && c.experiment == row.experiment
            && c.protocol == row.protocol
            && c.robots == row.robots
    })
}

/// Per seed that both have, `row`'s median held-out loss over the last 1000 s over its clean
/// point's (issue 56's acceptance; the final values where either run's summary predates the
/// median). Empty for a clean point.
fn ratios_to_clean(row: &Row, rows: &[Row]) -> Vec<f64> {
    if row.faulty == 0 {
        return Vec::new();
    }
    let Some(clean) = clean_of(row, rows) else {
        return Vec::new();
    };
    row.runs
        .iter()
        .filter_map(|run| {
            let base = clean.runs.iter().find(|c| c.seed == run.seed)?;
            let ratio = match (run.median_last, base.median_last) {
                (Some(m), Some(b)) => m / b,
                _ => run.heldout? / base.heldout?,
            };
            ratio.is_finite().then_some(ratio)
        })
        .collect()
}

/// The point's statistics among `stats`.
fn point_mut<'a>(stats: &'a mut [ExperimentStats], row: &Row) -> Option<&'a mut PointStats> {
    stats
        .iter_mut()
        .find(|e| e.name == row.experiment)?
        .points
        .iter_mut()
        .find(|p| p.point == row.point)
}

/// Adds the study's numbers to its points' metrics (so `numbers.csv` holds them) and makes
/// their held-out curves start at the genesis model (so `series.csv` holds what the figures
/// draw). Other experiments' statistics are left as they are.
pub fn extend(stats: &mut [ExperimentStats], rows: &[Row]) {
    type Reader = fn(&RunNumbers) -> Option<f64>;
    let metrics: [(&'static str, Reader); 9] = [
        ("heldout_loss_end", |r| r.heldout),
        ("heldout_of_genesis", RunNumbers::of_genesis),
        (
            "median_last_1000s_of_genesis",
            RunNumbers::median_of_genesis,
        ),
        ("submissions_accepted", |r| r.accepted),
        ("submissions_stale", |r| r.stale),
        ("submissions_refused", |r| r.refused),
        ("models_aggregated", |r| r.aggregated),
        ("faulty_models_aggregated", |r| r.faulty_aggregated),
        ("outlier", |r| r.outlier),
    ];
    for row in rows {
        let Some(p) = point_mut(stats, row) else {
            continue;
        };
        for (name, read) in metrics {
            if let Some(s) = row.stat(read) {
                p.metrics.insert(name, s);
            }
        }
        if let Some(s) = Stat::of(&row.ratio_to_clean) {
            p.metrics.insert("heldout_ratio_to_clean", s);
        }
        let curves: Vec<Box<dyn Fn(f64) -> Option<f64> + '_>> = row
            .runs
            .iter()
            .filter(|r| !r.heldout_times_s.is_empty())
            .map(|r| {
                Box::new(move |t: f64| stats::loss_at(&r.heldout_times_s, &r.heldout_losses, t))
                    as Box<dyn Fn(f64) -> Option<f64>>
            })
            .collect();
        if let Some(duration) = p.duration_s {
            p.heldout = stats::curve(duration, &curves);
        }
    }
}

/// The experiment whose section holds the study's figures and table: the first of the
/// study's experiments in the results.
fn home(rows: &[Row]) -> Option<&str> {
    rows.first().map(|r| r.experiment.as_str())
}

/// A row's legend label.
fn label(row: &Row) -> String {
    if row.faulty == 0 {
        row.protocol.clone()
    } else {
        format!("{}, {} faulty", row.protocol, row.faulty)
    }
}

/// The study's rows with their points' statistics.
fn with_stats<'a>(stats: &'a [ExperimentStats], rows: &'a [Row]) -> Vec<(&'a Row, &'a PointStats)> {
    rows.iter()
        .filter_map(|row| {
            let e = stats.iter().find(|e| e.name == row.experiment)?;
            Some((row, e.points.iter().find(|p| p.point == row.point)?))
        })
        .collect()
}

/// A figure to draw (`plots::Planned`), its plot owning its labels.
type Planned = plots::Planned<'static>;

/// Per swarm size, the held-out loss over time of each of its points.
fn heldout_over_time(points: &[(&Row, &PointStats)]) -> Vec<Planned> {
    let mut sizes: Vec<f64> = Vec::new();
    for (row, _) in points {
        if !sizes.contains(&row.robots) {
            sizes.push(row.robots);
        }
    }
    sizes
        .into_iter()
        .map(|robots| {
            let series = points
                .iter()
                .filter(|(row, _)| row.robots == robots)
                .map(|(row, p)| Series {
                    label: label(row),
                    points: p.heldout.clone(),
                })
                .collect();
            (
                format!("e6-scale-heldout-{robots}"),
                format!(
                    "e6-scale: held-out loss of the shared model over simulated time with {robots} \
                     robots, per protocol, from the genesis model's (mean, 95 % CI band, log \
                     scale; gossip: the robot that merged last)"
                ),
                Plot {
                    title: format!("e6-scale: held-out loss, {robots} robots"),
                    x_label: "time (s)",
                    y_label: "held-out loss",
                    kind: Kind::Time { log_y: true },
                    series,
                    nonnegative: true,
                    x_ticks: Vec::new(),
                },
            )
        })
        .collect()
}

/// A figure of one number versus the swarm's size, a series per protocol in `protocols`, over
/// the clean points.
struct Versus {
    stem: &'static str,
    caption: &'static str,
    title: &'static str,
    y_label: &'static str,
    log_y: bool,
    protocols: &'static [&'static str],
    read: fn(&PointStats) -> Option<Stat>,
}

/// The figures versus the swarm's size.
const VERSUS: [Versus; 7] = [
    Versus {
        stem: "e6-scale-median-heldout-of-genesis",
        caption: "e6-scale: median held-out loss of the shared model over the last 1000 s, as a \
                  fraction of the genesis model's, versus the swarm's size: the chain's \
                  protocols beside the matched ideal (the buffered rule without delay, \
                  staleness bound or outlier check) and gossip (mean, 95 % CI, log axes)",
        title: "e6-scale: median held-out loss, last 1000 s / genesis",
        y_label: "held-out loss / genesis",
        log_y: true,
        protocols: &["rounds", "buffered", "matched", "gossip"],
        read: |p| p.metrics.get("median_last_1000s_of_genesis").copied(),
    },
    Versus {
        stem: "e6-scale-final-heldout",
        caption: "e6-scale: final held-out loss of the shared model versus the swarm's size, per \
                  protocol (the genesis model's when no version was made; gossip: mean over \
                  honest robots; mean, 95 % CI, log axes)",
        title: "e6-scale: final held-out loss",
        y_label: "held-out loss",
        log_y: true,
        protocols: &["rounds", "buffered", "matched", "gossip"],
        read: |p| p.metrics.get("heldout_loss_end").copied(),
    },
    Versus {
        stem: "e6-scale-final-heldout-of-genesis",
        caption: "e6-scale: final held-out loss as a fraction of the genesis model's versus the \
                  swarm's size, per protocol (the targets are in world metres, so a larger \
                  arena starts from a larger loss; mean, 95 % CI, log axes)",
        title: "e6-scale: final held-out loss / genesis model's",
        y_label: "held-out loss / genesis",
        log_y: true,
        protocols: &["rounds", "buffered", "matched", "gossip"],
        read: |p| p.metrics.get("heldout_of_genesis").copied(),
    },
    Versus {
        stem: "e6-scale-versions",
        caption:
            "e6-scale: model versions made in the run versus the swarm's size (rounds: rounds \
                  closed; buffered: buffers aggregated; mean, 95 % CI, log x axis)",
        title: "e6-scale: model versions",
        y_label: "model versions",
        log_y: false,
        protocols: &["rounds", "buffered", "matched"],
        read: |p| p.metrics.get("rounds").copied(),
    },
    Versus {
        stem: "e6-scale-sent",
        caption: "e6-scale: bytes a node sends for aggregation (chain: gossip of blocks and \
                  transactions; gossip: its messages; lost ones included) versus the swarm's \
                  size (mean over nodes, then runs; 95 % CI, log axes)",
        title: "e6-scale: bytes sent per node",
        y_label: "sent per node (MB)",
        log_y: true,
        protocols: &["rounds", "buffered", "matched", "gossip"],
        read: |p| p.metrics.get("sent_mb_per_robot").copied(),
    },
    Versus {
        stem: "e6-scale-stored",
        caption: "e6-scale: bytes a node stores for aggregation at the end (chain: every block it \
                  holds; gossip: its replica) versus the swarm's size (mean over nodes, then \
                  runs; 95 % CI, log axes)",
        title: "e6-scale: bytes stored per node",
        y_label: "stored per node (MB)",
        log_y: true,
        protocols: &["rounds", "buffered", "matched", "gossip"],
        read: |p| p.metrics.get("stored_mb_per_robot").copied(),
    },
    Versus {
        stem: "e6-scale-wall",
        caption: "e6-scale: wall-clock time of a run versus the swarm's size (mean, 95 % CI, log \
                  axes; the machine's, not a deterministic number: timing.csv)",
        title: "e6-scale: wall time per run",
        y_label: "wall time per run (s)",
        log_y: true,
        protocols: &["rounds", "buffered", "matched", "gossip"],
        read: |p| p.wall_s,
    },
];

/// The figure of `v` over the clean points.
fn versus(v: &Versus, points: &[(&Row, &PointStats)]) -> Planned {
    let series = v
        .protocols
        .iter()
        .map(|protocol| Series {
            label: protocol.to_string(),
            points: points
                .iter()
                .filter(|(row, _)| row.faulty == 0 && row.protocol == *protocol)
                .filter_map(|(row, p)| (v.read)(p).map(|s| (row.robots, s)))
                .collect(),
        })
        .collect();
    (
        v.stem.to_string(),
        v.caption.to_string(),
        Plot {
            title: v.title.to_string(),
            x_label: "robots",
            y_label: v.y_label,
            kind: Kind::Scaling { log_y: v.log_y },
            series,
            nonnegative: true,
            x_ticks: Vec::new(),
        },
    )
}

/// Draws the study's figures into `out` (after [`extend`]) and returns them, under the
/// first of its experiments present.
fn draw_all(
    stats: &[ExperimentStats],
    rows: &[Row],
    out: &Path,
    notes: &mut Vec<String>,
) -> anyhow::Result<Vec<Figure>> {
    let mut figures = Vec::new();
    let Some(home) = home(rows) else {
        return Ok(figures);
    };
    let points = with_stats(stats, rows);
    let mut planned = heldout_over_time(&points);
    planned.extend(VERSUS.iter().map(|v| versus(v, &points)));
    let mut textless = Vec::new();
    draw_planned(planned, home, out, &mut figures, &mut textless)?;
    note_textless(&textless, notes);
    Ok(figures)
}

/// The study's tables (markdown): every point, then the points with faulty robots against
/// their clean point.
pub fn section(rows: &[Row]) -> String {
    let mut md = String::new();
    let protocols: Vec<&str> = E6_PROTOCOLS.iter().map(|(p, _)| *p).collect();
    let _ = writeln!(
        md,
        "The scale study ({}): protocols {} per swarm size at the paper's density. Per point, over \
         its runs: mean ± sample standard deviation (none for one run). Final held-out loss: the \
         shared model's at the end, the genesis model's when no version was made (gossip: the \
         mean over honest robots of their own models'); of genesis: that loss over the genesis \
         model's, per run (the targets are in world metres, so a larger arena starts from a \
         larger loss). Versions: rounds closed (rounds), buffers aggregated (buffered), merges of honest robots (gossip, which has no shared model). \
         Submissions on the final canonical chain by outcome: accepted (with the one that closed \
         a round or buffer), outlier, stale (a base more than `contract.max_staleness` versions \
         behind) and every other refusal (unknown, future or duplicate base, duplicate, \
         insufficient stake, malformed); gossip counts the models written. Bytes per node, in \
         MB: sent for aggregation (lost ones included) and stored at the end. Wall time: seconds \
         per run on the machine that ran it.\n",
        experiments().join(", "),
        protocols.join(", ")
    );
    let _ = writeln!(
        md,
        "| point | robots | faulty | runs | versions | final held-out loss | of genesis | accepted | outlier | stale | other refused | sent MB/node | stored MB/node | wall s/run |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for row in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            row.point,
            row.robots,
            row.faulty,
            row.runs.len(),
            text(row.spread(|r| r.versions), 1),
            text(row.spread(|r| r.heldout), 5),
            text(row.spread(RunNumbers::of_genesis), 4),
            text(row.spread(|r| r.accepted), 1),
            text(row.spread(|r| r.outlier), 1),
            text(row.spread(|r| r.stale), 1),
            text(row.spread(|r| r.refused), 1),
            text(row.spread(|r| r.sent_mb), 2),
            text(row.spread(|r| r.stored_mb), 2),
            text(row.spread(|r| r.wall_s), 1),
        );
    }
    md.push_str(&matched_table(rows));
    let faulty: Vec<&Row> = rows.iter().filter(|r| r.faulty > 0).collect();
    if faulty.is_empty() {
        return md;
    }
    let _ = writeln!(
        md,
        "\nThe points with faulty robots against the clean point of their protocol and size. \
         `summary.json` counts submissions by outcome over all senders, not per robot: a faulty \
         robot's model counts as aggregated when it passed the contract's check and went into \
         an aggregation, so 0 faulty models aggregated means that every faulty submission on \
         the chain was rejected or refused (save any still in an open round or buffer at the \
         end). Token change: the faulty robots' mean, in tokens (stakes of rejected submissions \
         are kept by the pool). Held-out ratio: per seed, the median held-out loss over the last \
         1000 s (the final value in summaries made before that median) over that of the clean \
         run of the same seed; worst: the largest.\n"
    );
    let _ = writeln!(
        md,
        "| point | runs | faulty models aggregated | models aggregated | faulty token change | final held-out loss | clean point | clean final held-out loss | held-out ratio | worst seed ratio |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    for row in faulty {
        let clean = clean_of(row, rows);
        let worst = row
            .ratio_to_clean
            .iter()
            .copied()
            .fold(None::<f64>, |m, r| Some(m.map_or(r, |m| m.max(r))));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            row.point,
            row.runs.len(),
            text(row.spread(|r| r.faulty_aggregated), 1),
            text(row.spread(|r| r.aggregated), 1),
            text(row.spread(|r| r.faulty_gain), 2),
            text(row.spread(|r| r.heldout), 5),
            clean.map_or("n/a", |c| c.point.as_str()),
            text(clean.and_then(|c| c.spread(|r| r.heldout)), 5),
            text(Spread::of(&row.ratio_to_clean), 2),
            worst.map_or_else(|| "n/a".to_string(), |w| fixed(w, 2)),
        );
    }
    md
}

/// The chain against its matched ideal per size (issue 56), and how stale the updates were:
/// per clean buffered point with a matched point of the same size, per seed that both have,
/// the median held-out loss over the last 1000 s as a fraction of genesis, buffered over
/// matched; then every clean point's base ages and version propagation. Empty without such
/// figures (summaries made before them).
fn matched_table(rows: &[Row]) -> String {
    let mut md = String::new();
    let clean = |protocol: &str, robots: f64| {
        rows.iter()
            .find(|r| r.faulty == 0 && r.protocol == protocol && r.robots == robots)
    };
    let mut ratio_lines = Vec::new();
    for chain in rows
        .iter()
        .filter(|r| r.faulty == 0 && r.protocol == "buffered")
    {
        let Some(ideal) = clean("matched", chain.robots) else {
            continue;
        };
        let ratios: Vec<f64> = chain
            .runs
            .iter()
            .filter_map(|run| {
                let i = ideal.runs.iter().find(|i| i.seed == run.seed)?;
                let ratio = run.median_of_genesis()? / i.median_of_genesis()?;
                ratio.is_finite().then_some(ratio)
            })
            .collect();
        let worst = ratios
            .iter()
            .copied()
            .fold(None::<f64>, |m, r| Some(m.map_or(r, |m| m.max(r))));
        ratio_lines.push(format!(
            "| {} | {} | {} | {} | {} |",
            chain.robots,
            text(chain.spread(RunNumbers::median_of_genesis), 4),
            text(ideal.spread(RunNumbers::median_of_genesis), 4),
            text(Spread::of(&ratios), 2),
            worst.map_or_else(|| "n/a".to_string(), |w| fixed(w, 2)),
        ));
    }
    if !ratio_lines.is_empty() {
        let _ = writeln!(
            md,
            "\nThe chain against its matched ideal: the buffered protocol beside an ideal server \
             applying the same rule to every K updates of the same trainings, with no delay, \
             staleness bound or outlier check (`learn.aggregation = matched`). Median held-out \
             loss over the last 1000 s as a fraction of the genesis model's; ratio: per seed, \
             chain over ideal (1 = the chain loses nothing to its delays and checks).\n\n\
             | robots | buffered, of genesis | matched ideal, of genesis | chain / ideal | worst seed |\n|---|---|---|---|---|"
        );
        for line in ratio_lines {
            let _ = writeln!(md, "{line}");
        }
    }
    let aged: Vec<&Row> = rows
        .iter()
        .filter(|r| {
            r.runs
                .iter()
                .any(|n| n.age_s.is_some() || n.propagation_s.is_some())
        })
        .collect();
    if aged.is_empty() {
        return md;
    }
    let _ = writeln!(
        md,
        "\nStaleness. Base age of the accepted updates: the versions between the one an update \
         trained from and the newest when it was executed, as shares of the updates at most 0, \
         1, 3 and 7 versions behind, and in seconds from the base's creation (median, p95, \
         mean over runs). Version propagation: per version and node, the time from the \
         version's first appearance at a node's head to this node's (chain only).\n\n\
         | point | age 0 | <= 1 | <= 3 | <= 7 | age median s | age p95 s | propagation median s | propagation p95 s |\n|---|---|---|---|---|---|---|---|---|"
    );
    for row in aged {
        let share = |v| text(row.spread(|r| r.age_share_within(v)), 2);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            row.point,
            share(0),
            share(1),
            share(3),
            share(7),
            text(row.spread(|r| r.age_s.map(|a| a.0)), 1),
            text(row.spread(|r| r.age_s.map(|a| a.1)), 1),
            text(row.spread(|r| r.propagation_s.map(|a| a.0)), 1),
            text(row.spread(|r| r.propagation_s.map(|a| a.1)), 1),
        );
    }
    md
}

#[cfg(test)]
mod tests;

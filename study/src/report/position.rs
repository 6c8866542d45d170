//! `e4-heterogeneity-measure` (issue 55): the position heterogeneity of the robots' training
//! data (`world.position_heterogeneity`, core's `world/heterogeneity.rs`) per home-range alpha,
//! swarm size and seed, beside the motion heterogeneity (`world.data_heterogeneity`). A table
//! per measure (rows: size and seed; columns: alpha, from roaming to few regions a robot),
//! whether each row rises as alpha falls, a CSV of every number and a figure of the means.

use std::fmt::Write as _;
use std::path::Path;

use super::load::RunResult;
use super::plots::{draw_planned, note_textless, Kind, Plot, Series};
use super::stats::{ExperimentStats, Stat};
use super::study::{drawn_by, Drawn, Section, StudyReport};
use crate::experiments::{DrawnBy, Entry, HETEROGENEITY_ALPHAS, HETEROGENEITY_SIZES};

/// The study report of the experiments drawn by [`DrawnBy::PositionMeasure`].
#[derive(Debug)]
pub struct PositionMeasure;

/// How a measure is read off a run.
type Get = fn(&RunResult) -> Option<f64>;

/// The measures tabled: name in the text, name in the CSV, and how to read it off a run.
const MEASURES: [(&str, &str, Get); 5] = [
    (
        "position: bias-corrected Cramér's V, mean over rounds",
        "position_cramers_v",
        |r| position(r).map(|p| p.cramers_v),
    ),
    (
        "position: Jensen-Shannon divergence (normalised), mean over rounds",
        "position_js_divergence",
        |r| position(r).map(|p| p.js_divergence),
    ),
    (
        "position: Cramér's V of the table summed over the run",
        "position_run_cramers_v",
        |r| position(r).map(|p| p.run_cramers_v),
    ),
    (
        "position: Jensen-Shannon divergence of the table summed over the run",
        "position_run_js_divergence",
        |r| position(r).map(|p| p.run_js_divergence),
    ),
    (
        "motion heterogeneity (`world.data_heterogeneity`, speed x turn, at the end)",
        "motion_heterogeneity",
        |r| Some(r.result.summary.run.world.data_heterogeneity),
    ),
];

fn position(r: &RunResult) -> Option<&swarmfl_core::world::heterogeneity::PositionHeterogeneity> {
    r.result.summary.run.world.position_heterogeneity.as_ref()
}

impl StudyReport for PositionMeasure {
    fn draws(&self, entry: Option<&Entry>) -> bool {
        entry.is_some_and(|e| e.drawn_by == DrawnBy::PositionMeasure)
    }

    fn draw(
        &self,
        results: &[RunResult],
        stats: &[ExperimentStats],
        out: &Path,
        notes: &mut Vec<String>,
    ) -> anyhow::Result<Drawn> {
        let mut drawn = Drawn::default();
        for e in drawn_by(self, stats) {
            let runs: Vec<&RunResult> = results.iter().filter(|r| r.experiment == e.name).collect();
            let mut text = String::from(
                "Per swarm size and seed, each measure per home-range alpha (columns from \
                 roaming to few regions a robot); `rises` says whether every step to a \
                 smaller alpha raised it.\n\n",
            );
            for (label, _, get) in MEASURES {
                let _ = writeln!(text, "**{label}**\n\n{}", table(&runs, get));
            }
            drawn.sections.push(Section {
                experiment: e.name.clone(),
                text,
            });
            drawn
                .files
                .push((format!("{}-heterogeneity.csv", e.name), csv(&runs)));
            let mut textless = Vec::new();
            draw_planned(
                [plan(&e.name, &runs)],
                &e.name,
                out,
                &mut drawn.figures,
                &mut textless,
            )?;
            note_textless(&textless, notes);
        }
        Ok(drawn)
    }
}

/// The run of `robots` robots, `alpha` and `seed`, if present.
fn find<'a>(runs: &[&'a RunResult], robots: u32, alpha: &str, seed: u64) -> Option<&'a RunResult> {
    let point = format!("alpha-{alpha}-{robots}");
    runs.iter()
        .find(|r| r.point == point && r.seed == seed)
        .copied()
}

/// The seeds present, ascending.
fn seeds(runs: &[&RunResult]) -> Vec<u64> {
    let mut s: Vec<u64> = runs.iter().map(|r| r.seed).collect();
    s.sort_unstable();
    s.dedup();
    s
}

/// Whether each value is above the one before.
fn rises(values: &[Option<f64>]) -> &'static str {
    if values.iter().any(Option::is_none) {
        "n/a"
    } else if values.windows(2).all(|w| w[1] > w[0]) {
        "yes"
    } else {
        "no"
    }
}

/// A markdown table of one measure: rows (robots, seed), columns alpha.
fn table(runs: &[&RunResult], get: Get) -> String {
    let mut md = String::from("| robots | seed |");
    for a in HETEROGENEITY_ALPHAS {
        let _ = write!(md, " alpha {a} |");
    }
    md.push_str(" rises |\n|---|---|");
    md.push_str(&"---|".repeat(HETEROGENEITY_ALPHAS.len() + 1));
    md.push('\n');
    for robots in HETEROGENEITY_SIZES {
        for seed in seeds(runs) {
            let values: Vec<Option<f64>> = HETEROGENEITY_ALPHAS
                .iter()
                .map(|a| find(runs, robots, a, seed).and_then(get))
                .collect();
            let _ = write!(md, "| {robots} | {seed} |");
            for v in &values {
                let _ = write!(md, " {} |", v.map_or("n/a".into(), |v| format!("{v:.3}")));
            }
            let _ = writeln!(md, " {} |", rises(&values));
        }
    }
    md
}

/// Every number: one line per run.
fn csv(runs: &[&RunResult]) -> String {
    let mut text = String::from("robots,alpha,seed");
    for (_, name, _) in MEASURES {
        text.push(',');
        text.push_str(name);
    }
    text.push_str(",rounds,trainings,cells\n");
    for robots in HETEROGENEITY_SIZES {
        for alpha in HETEROGENEITY_ALPHAS {
            for seed in seeds(runs) {
                let Some(r) = find(runs, robots, alpha, seed) else {
                    continue;
                };
                let _ = write!(text, "{robots},{alpha},{seed}");
                for (_, _, get) in MEASURES {
                    let _ = write!(text, ",{}", get(r).map_or(String::new(), |v| v.to_string()));
                }
                let (rounds, trainings, cells) =
                    position(r).map_or((0, 0, 0), |p| (p.rounds, p.trainings, p.cells));
                let _ = writeln!(text, ",{rounds},{trainings},{cells}");
            }
        }
    }
    text
}

/// The figure: the two per-round position measures versus alpha, per size (mean over seeds,
/// 95 % CI).
fn plan<'a>(name: &str, runs: &[&RunResult]) -> (String, String, Plot<'a>) {
    let mut series = Vec::new();
    for robots in HETEROGENEITY_SIZES {
        for (label, _, get) in &MEASURES[..2] {
            let points = HETEROGENEITY_ALPHAS
                .iter()
                .enumerate()
                .filter_map(|(i, a)| {
                    let values: Vec<f64> = seeds(runs)
                        .iter()
                        .filter_map(|&s| find(runs, robots, a, s).and_then(get))
                        .collect();
                    Stat::of(&values).map(|s| (i as f64, s))
                })
                .collect();
            let short = label.split(',').next().unwrap_or(label);
            series.push(Series {
                label: format!("{short}, {robots} robots"),
                points,
            });
        }
    }
    (
        format!("{name}-position"),
        format!(
            "{name}: position heterogeneity of the robots' training data (per-round Cramér's V \
             and normalised Jensen-Shannon divergence, mean over rounds) versus the home ranges' \
             alpha, per swarm size (mean over seeds, 95 % CI)"
        ),
        Plot {
            title: format!("{name}: position heterogeneity"),
            x_label: "world.home_range.alpha",
            y_label: "heterogeneity (0 same, 1 disjoint)",
            kind: Kind::Versus,
            series,
            nonnegative: true,
            x_ticks: HETEROGENEITY_ALPHAS
                .iter()
                .enumerate()
                .map(|(i, a)| (i as f64, a.to_string()))
                .collect(),
        },
    )
}

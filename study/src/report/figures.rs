//! The standard figures of an experiment: loss over time per point, tokens gained versus the
//! number of Byzantine robots, chain size over time; and those of `e0-baselines` (held-out
//! loss per condition, bytes per robot per aggregation).

use std::path::Path;

use super::coords::GridCoords;
use super::load::RunResult;
use super::plots::{draw_planned, note_textless, Figure, Kind, Planned, Plot, Series};
use super::stats::{ExperimentStats, PointStats, Stat};
use super::study::{drawn_by, Drawn, StudyReport};
use crate::experiments::{self, DrawnBy, Entry, Legend, Standard, AGGREGATIONS};

/// The study report of the standard figures: the experiments drawn by
/// [`DrawnBy::Standard`] and [`DrawnBy::Baselines`], and every experiment that is not built
/// in (a `--grid` sweep's).
#[derive(Debug)]
pub struct StandardFigures;

impl StudyReport for StandardFigures {
    fn draws(&self, entry: Option<&Entry>) -> bool {
        entry.is_none_or(|e| matches!(e.drawn_by, DrawnBy::Standard(_) | DrawnBy::Baselines))
    }

    fn draw(
        &self,
        _results: &[RunResult],
        stats: &[ExperimentStats],
        out: &Path,
        notes: &mut Vec<String>,
    ) -> anyhow::Result<Drawn> {
        Ok(Drawn {
            figures: draw_all(self, stats, out, notes)?,
            ..Drawn::default()
        })
    }
}

/// How the standard figures show `e`: as its entry says, else as [`Standard::OTHER`].
fn standard_of(e: &ExperimentStats) -> Standard {
    match experiments::entry(&e.name).map(|entry| entry.drawn_by) {
        Some(DrawnBy::Standard(s)) => s,
        _ => Standard::OTHER,
    }
}

/// Draws every figure the statistics allow into `out`, returning them (for report.md), for
/// the experiments `study` draws.
fn draw_all(
    study: &StandardFigures,
    stats: &[ExperimentStats],
    out: &Path,
    notes: &mut Vec<String>,
) -> anyhow::Result<Vec<Figure>> {
    let mut figures = Vec::new();
    let mut textless = Vec::new();
    for e in drawn_by(study, stats) {
        let entry = experiments::entry(&e.name);
        let planned = if entry.is_some_and(|entry| entry.drawn_by == DrawnBy::Baselines) {
            baselines(e)
        } else {
            standard(e, beside(e, stats))
        };
        draw_planned(planned, &e.name, out, &mut figures, &mut textless)?;
    }
    note_textless(&textless, notes);
    Ok(figures)
}

/// The point drawn beside `e`'s loss curves ([`Standard::beside`]) and its label, when the
/// statistics have it.
fn beside<'a>(
    e: &ExperimentStats,
    stats: &'a [ExperimentStats],
) -> Option<(&'static str, &'a PointStats)> {
    let b = standard_of(e).beside?;
    let other = stats.iter().find(|o| o.name == b.experiment)?;
    let point = other.points.iter().find(|p| p.point == b.point)?;
    Some((b.label, point))
}

/// The standard figures of an experiment: its loss, its tokens (where they apply) and its
/// chain size. `beside` is another experiment's point drawn beside the loss, and its label.
fn standard<'a>(e: &'a ExperimentStats, beside: Option<(&str, &PointStats)>) -> Vec<Planned<'a>> {
    let mut planned = vec![loss(e, beside)];
    planned.extend(tokens(e));
    planned.push(chain(e));
    planned
}

/// Loss over time, one line per point.
fn loss<'a>(e: &'a ExperimentStats, beside: Option<(&str, &PointStats)>) -> Planned<'a> {
    let mut loss: Vec<Series> = e
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| Series {
            label: label(e, i),
            points: p.loss.clone(),
        })
        .collect();
    if let Some((label, b)) = beside {
        loss.push(Series {
            label: label.into(),
            points: b.loss.clone(),
        });
    }
    let what = standard_of(e).loss;
    (
        format!("{}-loss", e.name),
        format!(
            "{}: average loss over time {what} (mean, 95 % CI band, log scale)",
            e.name
        ),
        Plot {
            title: format!("{}: average loss", e.name),
            x_label: "time (s)",
            y_label: "average loss",
            kind: Kind::Time { log_y: true },
            series: loss,
            nonnegative: true,
            x_ticks: Vec::new(),
        },
    )
}

/// Tokens versus the number of Byzantine robots: only where that is the grid (and where
/// tokens move at all: no figure of zeros for the runs without security).
fn tokens(e: &ExperimentStats) -> Option<Planned<'_>> {
    let tokens_move = e.points.iter().any(|p| {
        ["honest_gain", "byzantine_gain"]
            .iter()
            .any(|k| p.metrics.get(*k).is_some_and(|s| s.mean != 0.0))
    });
    let applies = e
        .points
        .iter()
        .any(|p| p.metrics.contains_key("honest_gain"))
        && e.points.len() > 1
        && standard_of(e).legend != Legend::ExpirationS
        && tokens_move;
    if !applies {
        return None;
    }
    if let Some(g) = &e.grid {
        return Some(grid_tokens(e, g));
    }
    let pick = |key: &str| -> Vec<(f64, Stat)> {
        e.points
            .iter()
            .filter_map(|p| p.metrics.get(key).map(|s| (p.x, *s)))
            .collect()
    };
    Some((
        format!("{}-tokens", e.name),
        format!(
            "{}: tokens gained by honest and by Byzantine robots versus their number (mean, 95 % CI)",
            e.name
        ),
        Plot {
            title: format!("{}: tokens gained", e.name),
            x_label: &e.axis,
            y_label: "tokens gained per robot",
            kind: Kind::Versus,
            nonnegative: false,
            series: vec![
                Series {
                    label: "honest robots".into(),
                    points: pick("honest_gain"),
                },
                Series {
                    label: "Byzantine robots".into(),
                    points: pick("byzantine_gain"),
                },
            ],
            x_ticks: Vec::new(),
        },
    ))
}

/// A grid's tokens figure: versus its x key ([`GridCoords::versus`]), its values as the ticks,
/// a pair of series (honest, Byzantine) per combination of the other keys.
fn grid_tokens<'a>(e: &'a ExperimentStats, g: &'a GridCoords) -> Planned<'a> {
    let v = g.versus();
    let mut combos: Vec<&str> = Vec::new();
    for s in &v.series {
        if !combos.contains(&s.as_str()) {
            combos.push(s);
        }
    }
    let mut series = Vec::new();
    for combo in &combos {
        for (key, who) in [
            ("honest_gain", "honest robots"),
            ("byzantine_gain", "Byzantine robots"),
        ] {
            series.push(Series {
                label: if combo.is_empty() {
                    who.to_string()
                } else {
                    format!("{who}, {combo}")
                },
                points: e
                    .points
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| v.series[*i] == *combo)
                    .filter_map(|(i, p)| p.metrics.get(key).map(|s| (v.x[i], *s)))
                    .collect(),
            });
        }
    }
    let x_key = &g.keys[g.x_key];
    let others: Vec<&str> = (0..g.keys.len())
        .filter(|&j| j != g.x_key)
        .map(|j| g.keys[j].as_str())
        .collect();
    let per = if others.is_empty() {
        String::new()
    } else {
        format!(", a pair of series per {}", others.join(" x "))
    };
    (
        format!("{}-tokens", e.name),
        format!(
            "{}: tokens gained by honest and by Byzantine robots versus {x_key}{per} (mean, 95 % CI)",
            e.name
        ),
        Plot {
            title: format!("{}: tokens gained", e.name),
            x_label: x_key,
            y_label: "tokens gained per robot",
            kind: Kind::Versus,
            nonnegative: false,
            series,
            x_ticks: v.ticks,
        },
    )
}

/// Chain size over time, one line per point.
fn chain(e: &ExperimentStats) -> Planned<'_> {
    (
        format!("{}-chain", e.name),
        format!(
            "{}: blockchain size over time (mean over nodes, then runs; 95 % CI)",
            e.name
        ),
        Plot {
            title: format!("{}: chain size", e.name),
            x_label: "time (s)",
            y_label: "chain size (MB)",
            kind: Kind::Time { log_y: false },
            nonnegative: true,
            series: e
                .points
                .iter()
                .enumerate()
                .map(|(i, p)| Series {
                    label: label(e, i),
                    points: p.chain_mb.clone(),
                })
                .collect(),
            x_ticks: Vec::new(),
        },
    )
}

/// The figures of `e0-baselines`: per Byzantine condition, the held-out loss over time of
/// the three aggregations; bytes sent and stored per robot versus the number of Byzantine
/// robots, one series per aggregation.
fn baselines(e: &ExperimentStats) -> Vec<Planned<'_>> {
    let mut figures = Vec::new();
    let name = &e.name;
    for (condition, what) in [
        ("clean", "no Byzantine robots"),
        ("faulty-1", "one faulty robot"),
        ("malicious-3", "three malicious robots"),
    ] {
        let series = AGGREGATIONS
            .iter()
            .filter_map(|a| {
                let name = format!("{a}-{condition}");
                e.points.iter().find(|p| p.point == name).map(|p| Series {
                    label: if *a == "chain" {
                        "chain (security on)".to_string()
                    } else {
                        a.to_string()
                    },
                    points: p.heldout.clone(),
                })
            })
            .collect();
        figures.push((
            format!("{name}-heldout-{condition}"),
            format!(
                "{name}: held-out loss of the aggregated model over time, {what} \
                 (mean, 95 % CI band, log scale; gossip: the robot that merged last)"
            ),
            Plot {
                title: format!("{name}: held-out loss, {what}"),
                x_label: "time (s)",
                y_label: "held-out loss",
                kind: Kind::Time { log_y: true },
                series,
                nonnegative: true,
                x_ticks: Vec::new(),
            },
        ));
    }
    for (key, what, y_label) in [
        (
            "sent_mb_per_robot",
            "bytes each robot sends for aggregation",
            "sent per robot (MB)",
        ),
        (
            "stored_mb_per_robot",
            "bytes each robot stores for aggregation at the end",
            "stored per robot (MB)",
        ),
    ] {
        let series = AGGREGATIONS
            .iter()
            .map(|a| Series {
                label: a.to_string(),
                points: e
                    .points
                    .iter()
                    .filter(|p| p.point.starts_with(&format!("{a}-")))
                    .filter_map(|p| p.metrics.get(key).map(|s| (p.x, *s)))
                    .collect(),
            })
            .collect();
        figures.push((
            format!("{name}-{}", key.replace('_', "-")),
            format!("{name}: {what} versus the number of Byzantine robots (mean, 95 % CI)"),
            Plot {
                title: format!("{name}: {y_label}"),
                x_label: &e.axis,
                y_label,
                kind: Kind::Versus,
                series,
                nonnegative: true,
                x_ticks: Vec::new(),
            },
        ));
    }
    figures
}

/// Point `i`'s legend label: a grid's `key=value` of every key, else by the experiment.
fn label(e: &ExperimentStats, i: usize) -> String {
    if let Some(g) = &e.grid {
        return g.label(i);
    }
    let (point, x) = (&e.points[i].point, e.points[i].x);
    if x.is_nan() {
        return point.to_string();
    }
    match standard_of(e).legend {
        Legend::ExpirationS => format!("expiration {x} s"),
        Legend::OneFaulty => "1 faulty robot".to_string(),
        Legend::Byzantine => format!("{x} Byzantine"),
    }
}

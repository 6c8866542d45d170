//! The figures of `swarmfl ranking`, in the report's style (`report::plots`: points with 95 %
//! error bars versus the Byzantine count, SVG and PNG). One set per Byzantine kind, one
//! series per ranking, setting (the other keys the runs differ on, `key=value` in the legend)
//! and group: `<kind>-gain` (Byzantine minus honest tokens gained, the
//! claim's quantity), `<kind>-tokens` (both groups' gains), `<kind>-rank` (mean rank of their
//! accepted submissions), `<kind>-position` (mean distance to the shared model over the
//! round's median distance) and `<kind>-median` (share of rounds whose median model is
//! Byzantine, and of rounds where every Byzantine model is closer to the shared model than
//! every honest one). The x axis is marked at each count measured; series at one count are
//! spread around it (`report::plots` does it) so that their bars do not hide each other.

use std::path::Path;

use super::measure::PointStats;
use crate::report::plots::{self, Kind, Plot, Series};

/// Draws every figure into `out`; returns whether their text could be drawn.
pub fn draw_all(points: &[PointStats], out: &Path) -> anyhow::Result<bool> {
    let mut kinds: Vec<&str> = points.iter().map(|(p, _)| p.kind.as_str()).collect();
    kinds.dedup();
    let mut with_text = true;
    for kind in kinds {
        let x_label = format!("{kind} robots");
        for (name, plot) in &kind_plots(points, kind, &x_label) {
            with_text &= plots::draw(plot, out, &format!("{kind}-{name}"))?;
        }
    }
    Ok(with_text)
}

/// The figures of the Byzantine kind `kind`, each with its name.
fn kind_plots<'a>(
    points: &[PointStats],
    kind: &str,
    x_label: &'a str,
) -> [(&'static str, Plot<'a>); 5] {
    let series = |metrics: &[(&str, &str)]| kind_series(points, kind, metrics);
    let mut counts: Vec<u32> = points
        .iter()
        .filter(|(p, _)| p.kind == kind)
        .map(|(p, _)| p.count)
        .collect();
    counts.sort_unstable();
    counts.dedup();
    let x_ticks: Vec<(f64, String)> = counts
        .iter()
        .map(|&c| (f64::from(c), c.to_string()))
        .collect();
    [
        (
            "gain",
            Plot {
                title: format!("{kind} minus honest tokens gained, per robot"),
                x_label,
                y_label: "tokens (mean gain of a Byzantine robot - of an honest one)",
                kind: Kind::Versus,
                series: series(&[("gain_difference", &format!("{kind} - honest"))]),
                nonnegative: false,
                x_ticks: x_ticks.clone(),
            },
        ),
        (
            "tokens",
            Plot {
                title: format!("tokens gained per robot, {kind} and honest"),
                x_label,
                y_label: "tokens gained per robot",
                kind: Kind::Versus,
                series: series(&[("byzantine_gain", kind), ("honest_gain", "honest")]),
                nonnegative: false,
                x_ticks: x_ticks.clone(),
            },
        ),
        (
            "rank",
            Plot {
                title: format!("mean rank of the accepted submissions, {kind} and honest"),
                x_label,
                y_label: "rank (1 = paid best)",
                kind: Kind::Versus,
                series: series(&[("byzantine_rank", kind), ("honest_rank", "honest")]),
                nonnegative: true,
                x_ticks: x_ticks.clone(),
            },
        ),
        (
            "position",
            Plot {
                title: format!(
                    "distance to the shared model over the round's median, {kind} and honest"
                ),
                x_label,
                y_label: "distance / median distance (1 = on the median)",
                kind: Kind::Versus,
                series: series(&[
                    ("byzantine_distance_ratio", kind),
                    ("honest_distance_ratio", "honest"),
                ]),
                nonnegative: true,
                x_ticks: x_ticks.clone(),
            },
        ),
        (
            "median",
            Plot {
                title: format!("who holds the median distance ({kind} robots)"),
                x_label,
                y_label: "share of rounds",
                kind: Kind::Versus,
                series: series(&[
                    ("median_byzantine", &format!("median model is {kind}")),
                    (
                        "byzantine_below_honest",
                        &format!("every {kind} model nearer than every honest one"),
                    ),
                ]),
                nonnegative: true,
                x_ticks: x_ticks.clone(),
            },
        ),
    ]
}

/// The series of `kind`'s figure of `metrics` (`(metric, label)` each): one per line and
/// metric; a series' label names the group, the ranking and the setting.
fn kind_series(points: &[PointStats], kind: &str, metrics: &[(&str, &str)]) -> Vec<Series> {
    // The lines of a figure: a ranking and the other keys' values (`Point::setting`).
    let mut lines: Vec<(&str, &[(String, String)])> = points
        .iter()
        .filter(|(p, _)| p.kind == kind)
        .map(|(p, _)| (p.ranking.as_str(), p.setting.as_slice()))
        .collect();
    lines.sort_unstable();
    lines.dedup();
    let mut out = Vec::new();
    for (ranking, setting) in &lines {
        for (metric, label) in metrics {
            let pts = points
                .iter()
                .filter(|(p, _)| p.kind == kind && p.ranking == *ranking && p.setting == *setting)
                .filter_map(|(p, stats)| {
                    let s = stats.iter().find(|(n, _)| n == metric)?.1?;
                    Some((f64::from(p.count), s))
                })
                .collect();
            let mut label = format!("{label}, {ranking} ranking");
            for (k, v) in *setting {
                label.push_str(&format!(", {k}={v}"));
            }
            out.push(Series { label, points: pts });
        }
    }
    out
}

//! `e5-smart-defence`: token gains of honest and Byzantine robots and the final held-out loss
//! per number of smart robots, one series per defence (`contract.defence`), the same for
//! `smart-then-collude`, and a table of when the Byzantine robots took control of the tokens
//! (`tokens.byzantine_control` of `summary.json`). Points carry `defence` and `attack` tags
//! (see `experiments::experiment`).

use std::fmt::Write as _;
use std::path::Path;

use super::load::RunResult;
use super::plots::{draw_planned, note_textless, Figure, Kind, Plot, Series};
use super::stats::{ExperimentStats, PointStats, Stat};
use super::study::{drawn_by, Drawn, Section, StudyReport};
use crate::experiments::{DrawnBy, Entry};

/// The study report of the experiments drawn by [`DrawnBy::Defence`].
#[derive(Debug)]
pub struct Defence;

impl StudyReport for Defence {
    fn draws(&self, entry: Option<&Entry>) -> bool {
        entry.is_some_and(|e| e.drawn_by == DrawnBy::Defence)
    }

    fn draw(
        &self,
        _results: &[RunResult],
        stats: &[ExperimentStats],
        out: &Path,
        notes: &mut Vec<String>,
    ) -> anyhow::Result<Drawn> {
        let mut drawn = Drawn::default();
        for e in drawn_by(self, stats) {
            drawn.figures.extend(draw_all(e, out, notes)?);
            drawn.sections.push(Section {
                experiment: e.name.clone(),
                text: format!(
                    "When the Byzantine robots held more than `byzantine.switch_token_share` of \
                     the balances on the final chain (`tokens.byzantine_control`; \
                     `smart-then-collude` switches then):\n\n{}",
                    control_table(e)
                ),
            });
        }
        Ok(drawn)
    }
}

fn tag<'a>(p: &'a PointStats, defence: &str) -> Option<&'a str> {
    // Point names are `<defence>--<attack>--<count>`.
    let mut parts = p.point.split("--");
    let d = parts.next()?;
    let attack = parts.next()?;
    (d == defence).then_some(attack)
}

fn defences(e: &ExperimentStats) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for p in &e.points {
        if let Some(d) = p.point.split("--").next() {
            if !out.iter().any(|x| x == d) {
                out.push(d.to_string());
            }
        }
    }
    out
}

/// `metric` over the points of `defence` whose attack is one of `attacks`, by count.
fn series(e: &ExperimentStats, defence: &str, attacks: &[&str], metric: &str) -> Vec<(f64, Stat)> {
    e.points
        .iter()
        .filter(|p| tag(p, defence).is_some_and(|a| attacks.contains(&a)))
        .filter_map(|p| p.metrics.get(metric).map(|s| (p.x, *s)))
        .collect()
}

/// Draws the figures of `e` into `out`.
fn draw_all(
    e: &ExperimentStats,
    out: &Path,
    notes: &mut Vec<String>,
) -> anyhow::Result<Vec<Figure>> {
    let mut figures = Vec::new();
    let name = &e.name;
    let defences = defences(e);
    let mut textless = Vec::new();
    let attacks: [(&str, &[&str], &str); 2] = [
        ("smart", &["none", "smart"], "smart robots"),
        (
            "switch",
            &["smart-then-collude"],
            "smart-then-collude robots",
        ),
    ];
    for (stem_part, kinds, axis) in attacks {
        let mut tokens = Vec::new();
        let mut loss = Vec::new();
        for d in &defences {
            for (group, metric) in [("honest", "honest_gain"), ("Byzantine", "byzantine_gain")] {
                tokens.push(Series {
                    label: format!("{group}, defence {d}"),
                    points: series(e, d, kinds, metric),
                });
            }
            loss.push(Series {
                label: format!("defence {d}"),
                points: series(e, d, kinds, "final_heldout_loss"),
            });
        }
        let plots = [
            (
                format!("{name}-{stem_part}-tokens"),
                format!(
                    "{name}: tokens gained by honest and by Byzantine robots versus the number of {axis}, per defence (mean, 95 % CI)"
                ),
                Plot {
                    title: format!("{name}: tokens gained ({axis})"),
                    x_label: axis,
                    y_label: "tokens gained per robot",
                    kind: Kind::Versus,
                    series: tokens,
                    nonnegative: false,
                    x_ticks: Vec::new(),
                },
            ),
            (
                format!("{name}-{stem_part}-heldout"),
                format!(
                    "{name}: final held-out loss of the shared model versus the number of {axis}, per defence (mean, 95 % CI)"
                ),
                Plot {
                    title: format!("{name}: final held-out loss ({axis})"),
                    x_label: axis,
                    y_label: "held-out loss",
                    kind: Kind::Versus,
                    series: loss,
                    nonnegative: true,
                    x_ticks: Vec::new(),
                },
            ),
        ];
        draw_planned(plots, name, out, &mut figures, &mut textless)?;
    }
    note_textless(&textless, notes);
    Ok(figures)
}

/// A markdown table of the Byzantine takeover of the tokens: per point with Byzantine robots,
/// in how many runs their share of the balances passed `byzantine.switch_token_share` on the
/// final chain, when (mean time), and the held-out loss then and at the end.
fn control_table(e: &ExperimentStats) -> String {
    let mut md = String::from(
        "| point | runs | runs with control | control at (s) | held-out loss at control | final held-out loss |\n|---|---|---|---|---|---|\n",
    );
    let text =
        |s: Option<&Stat>, digits: usize| s.map_or_else(|| "n/a".to_string(), |s| s.text(digits));
    for p in e.points.iter().filter(|p| p.x > 0.0) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            p.point,
            p.seeds.len(),
            p.metrics.get("control_time_s").map_or(0, |s| s.n),
            text(p.metrics.get("control_time_s"), 0),
            text(p.metrics.get("control_heldout_loss"), 5),
            text(p.metrics.get("final_heldout_loss"), 5),
        );
    }
    md
}

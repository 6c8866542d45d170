//! `e4-robustness`: heatmaps of rule x attack per Byzantine count (final held-out loss;
//! honest minus Byzantine mean token gain) and each rule's worst-case attack, from the points'
//! `rule` and `attack` tags (see `experiments::experiment`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use super::heatmap::{draw, Heatmap};
use super::load::RunResult;
use super::plots::Figure;
use super::stats::{fixed, ExperimentStats};
use super::study::{drawn_by, Drawn, Section, StudyReport};
use crate::experiments::{self, DrawnBy, Entry};

/// The worst-case table's CSV file.
const WORST_CASE_CSV: &str = "e4-worst-case.csv";

/// The study report of the experiments drawn by [`DrawnBy::Robustness`].
#[derive(Debug)]
pub struct Robustness;

impl StudyReport for Robustness {
    fn draws(&self, entry: Option<&Entry>) -> bool {
        entry.is_some_and(|e| e.drawn_by == DrawnBy::Robustness)
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
            let (table, csv) = worst_case(e);
            drawn.files.push((WORST_CASE_CSV.to_string(), csv));
            drawn.sections.push(Section {
                experiment: e.name.clone(),
                text: format!(
                    "Worst case: for each rule, the attack that leaves the highest final held-out \
                     loss at each Byzantine count, and that loss as a multiple of the rule's clean \
                     run (`{WORST_CASE_CSV}`).\n\n{table}"
                ),
            });
        }
        Ok(drawn)
    }
}

/// One cell: a rule against an attack at a count, with the means over its runs.
#[derive(Clone, Debug)]
pub struct Cell {
    /// The aggregation rule.
    pub rule: String,
    /// The attack (`none` for the clean point).
    pub attack: String,
    /// Byzantine robots.
    pub count: u32,
    /// Runs.
    pub runs: usize,
    /// Mean final held-out loss.
    pub loss: Option<f64>,
    /// Mean honest gain minus mean Byzantine gain, in tokens (`None` without Byzantine robots).
    pub gap: Option<f64>,
}

/// The cells of the experiment's results, in grid order.
pub fn cells(e: &ExperimentStats) -> Vec<Cell> {
    let Ok(grid) = experiments::experiment(&e.name) else {
        return Vec::new();
    };
    e.points
        .iter()
        .filter_map(|p| {
            let point = grid.points.iter().find(|g| g.name == p.point)?;
            let tag = |k: &str| point.tag(k);
            let mean = |k: &str| p.metrics.get(k).map(|s| s.mean);
            Some(Cell {
                rule: tag("rule")?,
                attack: tag("attack")?,
                count: point.x as u32,
                runs: p.seeds.len(),
                loss: mean("final_heldout_loss"),
                gap: match (mean("honest_gain"), mean("byzantine_gain")) {
                    (Some(h), Some(b)) => Some(h - b),
                    _ => None,
                },
            })
        })
        .collect()
}

/// Rows (rules) and columns (attacks, `none` first) in grid order.
fn axes(cells: &[Cell]) -> (Vec<String>, Vec<String>) {
    let mut rules: Vec<String> = Vec::new();
    let mut attacks: Vec<String> = vec!["none".to_string()];
    for c in cells {
        if !rules.contains(&c.rule) {
            rules.push(c.rule.clone());
        }
        if !attacks.contains(&c.attack) {
            attacks.push(c.attack.clone());
        }
    }
    (rules, attacks)
}

/// Draws the heatmaps of `e` into `out` and returns them.
fn draw_all(
    e: &ExperimentStats,
    out: &Path,
    notes: &mut Vec<String>,
) -> anyhow::Result<Vec<Figure>> {
    let mut figures = Vec::new();
    let name = &e.name;
    let cells = cells(e);
    let (rules, attacks) = axes(&cells);
    let counts: Vec<u32> = {
        let mut c: Vec<u32> = cells.iter().map(|c| c.count).filter(|&c| c > 0).collect();
        c.sort_unstable();
        c.dedup();
        c
    };
    let lookup: BTreeMap<(&str, &str, u32), &Cell> = cells
        .iter()
        .map(|c| ((c.rule.as_str(), c.attack.as_str(), c.count), c))
        .collect();
    for &count in &counts {
        let value = |rule: &str, attack: &str, f: &dyn Fn(&Cell) -> Option<f64>| {
            let key_count = if attack == "none" { 0 } else { count };
            lookup.get(&(rule, attack, key_count)).and_then(|c| f(c))
        };
        let loss = Heatmap {
            title: format!("{name}: final held-out loss, {count} Byzantine of 15"),
            row_title: "aggregation rule".to_string(),
            col_title: "attack (none: the rule's clean run)".to_string(),
            value_title: "final held-out loss, mean over runs (log scale)".to_string(),
            rows: rules.clone(),
            cols: attacks.clone(),
            values: rules
                .iter()
                .map(|r| attacks.iter().map(|a| value(r, a, &|c| c.loss)).collect())
                .collect(),
            diverging: false,
            labels: Vec::new(),
            shared_scale: None,
        };
        let gap_cols: Vec<String> = attacks.iter().filter(|a| *a != "none").cloned().collect();
        let gap = Heatmap {
            title: format!("{name}: honest minus Byzantine token gain, {count} Byzantine of 15"),
            row_title: "aggregation rule".to_string(),
            col_title: "attack".to_string(),
            value_title: "honest minus Byzantine mean gain, tokens (blue: honest robots gain more)"
                .to_string(),
            rows: rules.clone(),
            cols: gap_cols.clone(),
            values: rules
                .iter()
                .map(|r| gap_cols.iter().map(|a| value(r, a, &|c| c.gap)).collect())
                .collect(),
            diverging: true,
            labels: Vec::new(),
            shared_scale: None,
        };
        for (stem, caption, map) in [
            (
                format!("{name}-loss-b{count}"),
                format!(
                    "{name}: final held-out loss per rule (rows) and attack (columns) with \
                     {count} Byzantine robots; column `none` is the rule's clean run (mean over runs)"
                ),
                loss,
            ),
            (
                format!("{name}-tokens-b{count}"),
                format!(
                    "{name}: honest minus Byzantine mean token gain per rule and attack with \
                     {count} Byzantine robots (positive: the contract pays honest robots more)"
                ),
                gap,
            ),
        ] {
            if map.values.iter().flatten().all(Option::is_none) {
                continue;
            }
            if !draw(&map, out, &stem)? {
                notes.push(format!("no font could be loaded: {stem} drawn without text"));
            }
            figures.push(Figure {
                experiment: name.clone(),
                stem,
                caption,
            });
        }
    }
    Ok(figures)
}

/// The worst-case table (markdown) and its CSV: per rule, its clean loss and, per count, the
/// attack with the highest final held-out loss.
fn worst_case(e: &ExperimentStats) -> (String, String) {
    let cells = cells(e);
    let (rules, _) = axes(&cells);
    let mut counts: Vec<u32> = cells.iter().map(|c| c.count).filter(|&c| c > 0).collect();
    counts.sort_unstable();
    counts.dedup();
    let mut md = String::new();
    let mut csv = String::from("rule,count,clean_loss,worst_attack,worst_loss,ratio,runs\n");
    let mut columns: Vec<String> = ["rule", "clean loss"].map(String::from).into();
    columns.extend(
        counts
            .iter()
            .map(|c| format!("worst attack, {c} Byzantine (loss, x clean)")),
    );
    super::markdown::header(&mut md, &columns);
    for rule in &rules {
        let clean = cells
            .iter()
            .find(|c| &c.rule == rule && c.count == 0)
            .and_then(|c| c.loss);
        let _ = write!(
            md,
            "| {rule} | {} |",
            clean.map_or_else(|| "n/a".to_string(), |l| fixed(l, 5))
        );
        for &count in &counts {
            // Highest loss; ties to the earlier attack in grid order.
            let worst = cells
                .iter()
                .filter(|c| &c.rule == rule && c.count == count)
                .filter_map(|c| c.loss.map(|l| (c, l)))
                .fold(None::<(&Cell, f64)>, |best, (c, l)| match best {
                    Some((_, b)) if b >= l => best,
                    _ => Some((c, l)),
                });
            match worst {
                Some((c, l)) => {
                    let ratio = clean.map(|k| l / k);
                    let _ = write!(
                        md,
                        " {} ({}, {}) |",
                        c.attack,
                        fixed(l, 5),
                        ratio.map_or_else(|| "n/a".to_string(), |r| format!("{r:.2}x"))
                    );
                    let _ = writeln!(
                        csv,
                        "{rule},{count},{},{},{l:e},{},{}",
                        clean.map_or_else(String::new, |k| format!("{k:e}")),
                        c.attack,
                        ratio.map_or_else(String::new, |r| format!("{r:e}")),
                        c.runs
                    );
                }
                None => {
                    let _ = write!(md, " n/a |");
                }
            }
        }
        let _ = writeln!(md);
    }
    (md, csv)
}

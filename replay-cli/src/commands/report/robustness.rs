//! `e4-robustness`: heatmaps of rule x attack per Byzantine count (final held-out loss;
//! honest minus Byzantine mean token gain) and each rule's worst-case attack, from the points'
//! `rule` and `attack` tags (see `experiments::experiment`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::plots::Figure;
use super::stats::ExperimentStats;
use crate::experiments;

/// The experiment this module draws.
pub const EXPERIMENT: &str = "e4-robustness";

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
    let Ok(grid) = experiments::experiment(EXPERIMENT) else {
        return Vec::new();
    };
    e.points
        .iter()
        .filter_map(|p| {
            let point = grid.points.iter().find(|g| g.name == p.point)?;
            let tag = |k: &str| {
                point
                    .tags
                    .iter()
                    .find(|(t, _)| *t == k)
                    .map(|(_, v)| v.clone())
            };
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

/// A heatmap's values: `values[row][col]`.
struct Heatmap {
    title: String,
    rows: Vec<String>,
    cols: Vec<String>,
    values: Vec<Vec<Option<f64>>>,
    /// Diverging colours around 0 (blue positive, red negative); else white (low) to red
    /// (high).
    diverging: bool,
}

/// Draws the heatmaps into `out` and returns them.
pub fn draw_all(
    stats: &[ExperimentStats],
    out: &Path,
    notes: &mut Vec<String>,
) -> anyhow::Result<Vec<Figure>> {
    let mut figures = Vec::new();
    let Some(e) = stats.iter().find(|e| e.name == EXPERIMENT) else {
        return Ok(figures);
    };
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
            title: format!("{EXPERIMENT}: final held-out loss, {count} Byzantine of 15"),
            rows: rules.clone(),
            cols: attacks.clone(),
            values: rules
                .iter()
                .map(|r| attacks.iter().map(|a| value(r, a, &|c| c.loss)).collect())
                .collect(),
            diverging: false,
        };
        let gap_cols: Vec<String> = attacks.iter().filter(|a| *a != "none").cloned().collect();
        let gap = Heatmap {
            title: format!(
                "{EXPERIMENT}: honest minus Byzantine token gain, {count} Byzantine of 15"
            ),
            rows: rules.clone(),
            cols: gap_cols.clone(),
            values: rules
                .iter()
                .map(|r| gap_cols.iter().map(|a| value(r, a, &|c| c.gap)).collect())
                .collect(),
            diverging: true,
        };
        for (stem, caption, map) in [
            (
                format!("{EXPERIMENT}-loss-b{count}"),
                format!(
                    "{EXPERIMENT}: final held-out loss per rule (rows) and attack (columns) with \
                     {count} Byzantine robots; column `none` is the rule's clean run (mean over runs)"
                ),
                loss,
            ),
            (
                format!("{EXPERIMENT}-tokens-b{count}"),
                format!(
                    "{EXPERIMENT}: honest minus Byzantine mean token gain per rule and attack with \
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
                experiment: EXPERIMENT.to_string(),
                stem,
                caption,
            });
        }
    }
    Ok(figures)
}

/// The worst-case table (markdown) and its CSV: per rule, its clean loss and, per count, the
/// attack with the highest final held-out loss.
pub fn worst_case(e: &ExperimentStats) -> (String, String) {
    let cells = cells(e);
    let (rules, _) = axes(&cells);
    let mut counts: Vec<u32> = cells.iter().map(|c| c.count).filter(|&c| c > 0).collect();
    counts.sort_unstable();
    counts.dedup();
    let mut md = String::new();
    let mut csv = String::from("rule,count,clean_loss,worst_attack,worst_loss,ratio,runs\n");
    let _ = write!(md, "| rule | clean loss |");
    for c in &counts {
        let _ = write!(md, " worst attack, {c} Byzantine (loss, x clean) |");
    }
    let _ = write!(md, "\n|---|---|");
    for _ in &counts {
        let _ = write!(md, "---|");
    }
    let _ = writeln!(md);
    for rule in &rules {
        let clean = cells
            .iter()
            .find(|c| &c.rule == rule && c.count == 0)
            .and_then(|c| c.loss);
        let _ = write!(
            md,
            "| {rule} | {} |",
            clean.map_or_else(|| "n/a".to_string(), |l| format!("{l:.5}"))
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
                        " {} ({l:.5}, {}) |",
                        c.attack,
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

fn colour(map: &Heatmap, v: f64, lo: f64, hi: f64) -> RGBColor {
    let mix = |a: (f64, f64, f64), b: (f64, f64, f64), t: f64| {
        let t = t.clamp(0.0, 1.0);
        RGBColor(
            (a.0 + (b.0 - a.0) * t) as u8,
            (a.1 + (b.1 - a.1) * t) as u8,
            (a.2 + (b.2 - a.2) * t) as u8,
        )
    };
    let white = (255.0, 255.0, 255.0);
    if map.diverging {
        let m = lo.abs().max(hi.abs()).max(1e-12);
        if v >= 0.0 {
            mix(white, (33.0, 102.0, 172.0), v / m)
        } else {
            mix(white, (178.0, 24.0, 43.0), -v / m)
        }
    } else {
        // Log scale: losses span orders of magnitude under attack.
        let (l, h) = (lo.max(1e-12).ln(), hi.max(1e-12).ln());
        let t = if h > l {
            (v.max(1e-12).ln() - l) / (h - l)
        } else {
            0.0
        };
        mix(white, (178.0, 24.0, 43.0), t)
    }
}

/// Draws `map` as `stem.svg` and `stem.png`; returns whether the text could be drawn.
fn draw(map: &Heatmap, out: &Path, stem: &str) -> anyhow::Result<bool> {
    let svg = out.join(format!("{stem}.svg"));
    let png = out.join(format!("{stem}.png"));
    let size = (
        140 + 90 * map.cols.len() as u32,
        120 + 40 * map.rows.len() as u32,
    );
    for text in [true, false] {
        let result = (|| -> Result<(), String> {
            let root = SVGBackend::new(&svg, size).into_drawing_area();
            draw_on(&root, map, text).map_err(|e| e.to_string())?;
            root.present().map_err(|e| e.to_string())?;
            crate::png::draw_png(&png, size, |root| {
                draw_on(root, map, text).map_err(|e| e.to_string())
            })
        })();
        match result {
            Ok(()) => return Ok(text),
            Err(_) if text => {}
            Err(e) => anyhow::bail!("cannot draw {stem}: {e}"),
        }
    }
    Ok(false)
}

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

fn draw_on<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &Heatmap,
    text: bool,
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    let values: Vec<f64> = map.values.iter().flatten().flatten().copied().collect();
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (nc, nr) = (map.cols.len() as i32, map.rows.len() as i32);
    let mut builder = ChartBuilder::on(root);
    builder.margin(12);
    if text {
        builder
            .caption(&map.title, ("sans-serif", 18))
            .x_label_area_size(70)
            .y_label_area_size(130);
    }
    let mut chart = builder.build_cartesian_2d(0..nc, 0..nr)?;
    for (r, row) in map.values.iter().enumerate() {
        let y = nr - 1 - r as i32;
        for (c, v) in row.iter().enumerate() {
            let x = c as i32;
            let fill = match v {
                Some(v) => colour(map, *v, lo, hi).filled(),
                None => RGBColor(220, 220, 220).filled(),
            };
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x, y), (x + 1, y + 1)],
                fill,
            )))?;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x, y), (x + 1, y + 1)],
                BLACK.mix(0.2).stroke_width(1),
            )))?;
            if text {
                let label = v.map_or_else(|| "n/a".to_string(), |v| format!("{v:.3}"));
                let (px, py) = chart.backend_coord(&(x, y + 1));
                let (qx, qy) = chart.backend_coord(&(x + 1, y));
                root.draw(&Text::new(
                    label,
                    ((px + qx) / 2 - 18, (py + qy) / 2 - 6),
                    ("sans-serif", 12).into_font().color(&BLACK),
                ))?;
            }
        }
    }
    if text {
        // Axis labels at the center of each row and column (plotters' mesh labels sit on the
        // cell boundaries of an integer axis).
        for (c, name) in map.cols.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(c as i32, 0));
            let (qx, _) = chart.backend_coord(&(c as i32 + 1, 0));
            let style = ("sans-serif", 12)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Center, VPos::Top));
            root.draw(&Text::new(name.clone(), ((px + qx) / 2, py + 8), style))?;
        }
        for (r, name) in map.rows.iter().enumerate() {
            let y = nr - 1 - r as i32;
            let (px, py) = chart.backend_coord(&(0, y));
            let (_, qy) = chart.backend_coord(&(0, y + 1));
            let style = ("sans-serif", 13)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Right, VPos::Center));
            root.draw(&Text::new(name.clone(), (px - 8, (py + qy) / 2), style))?;
        }
    }
    Ok(())
}

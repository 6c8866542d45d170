//! `e4-heterogeneity` (issue #55): the robustness benchmark on the home-range knob. Home ranges
//! change the task (the genesis model's held-out loss falls from about 3.5 roaming to about
//! 1.8 at alpha 0.1), so every loss here is a fraction of its own run's genesis held-out loss
//! (`heldout_loss_initial`), and 1 is a model that learned nothing.
//!
//! Per rule, alpha and Byzantine count: the worst case over the attacks (the attack whose mean
//! fraction over the seeds is highest, ties to the earlier attack in grid order; at count 0
//! the clean run) with that attack's per-seed min, median and max; the destroyed runs over
//! every attack and seed (`e4-benchmark`'s definition: final held-out loss above the genesis
//! model's) with a 95 % Wilson interval. Figures: per Byzantine count a heatmap of rule x
//! alpha of the worst case, each cell labelled with its destroyed runs. Tables: destroyed runs
//! per cell, the worst case with its per-seed spread, destroyed runs per seed (does one seed's
//! draw of attackers and phases decide a cell?), and the clean FedAvg per alpha (does it still
//! learn?). Files: `<experiment>-cells.csv` (one line per rule, alpha and count) and
//! `<experiment>-runs.csv` (one line per run).

mod tables;

use std::path::Path;

use super::heatmap::{draw, Heatmap, Scale};
use super::load::RunResult;
use super::plots::Figure;
use super::stats::ExperimentStats;
use super::study::{drawn_by, Drawn, Section, StudyReport};
use crate::experiments::{self, DrawnBy, Entry};
use crate::summary::Summary;

/// The study report of the experiments drawn by [`DrawnBy::Heterogeneity`].
#[derive(Debug)]
pub struct Heterogeneity;

impl StudyReport for Heterogeneity {
    fn draws(&self, entry: Option<&Entry>) -> bool {
        entry.is_some_and(|e| e.drawn_by == DrawnBy::Heterogeneity)
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
            let Some(h) = study(results, &e.name) else {
                continue;
            };
            drawn.figures.extend(draw_maps(&h, out, notes)?);
            drawn
                .files
                .push((format!("{}-cells.csv", h.experiment), tables::cells_csv(&h)));
            drawn
                .files
                .push((format!("{}-runs.csv", h.experiment), tables::runs_csv(&h)));
            drawn.sections.push(Section {
                experiment: e.name.clone(),
                text: tables::markdown(&h),
            });
        }
        Ok(drawn)
    }
}

/// One run: its seed, its genesis model's held-out loss and its final one.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// The seed.
    pub seed: u64,
    /// The genesis model's held-out loss (`heldout_loss_initial`).
    pub genesis: f64,
    /// The final held-out loss (the summary's own, else the last aggregation's); infinite
    /// when the model's loss is not a number any more.
    pub last: f64,
    /// Submissions the contract judged outliers on the final canonical chain
    /// (`submissions.outlier`).
    pub outliers: u64,
    /// Submissions counted for their rounds: accepted, aggregated or outliers.
    pub counted: u64,
    /// The mean distance of the accepted honest submissions to the shared model
    /// (`mean_honest_distance`), if any.
    pub honest_distance: Option<f64>,
    /// The largest round's mean of it (`mean_honest_distance_by_round`), if any.
    pub honest_distance_max_round: Option<f64>,
    /// The contract's outlier threshold (`outlier_threshold`).
    pub threshold: f64,
}

impl Run {
    /// The final held-out loss as a fraction of the genesis model's.
    pub fn fraction(&self) -> f64 {
        self.last / self.genesis
    }

    /// Whether the run's model was destroyed: its final held-out loss above the genesis
    /// model's (`e4-benchmark`'s definition).
    pub fn destroyed(&self) -> bool {
        self.last > self.genesis
    }
}

/// One point's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    /// The home-range alpha as the grid writes it (`inf`, `0.1`).
    pub alpha: String,
    /// The rule (`nnm+median`, `gate+median`).
    pub rule: String,
    /// The attack (`none` at count 0).
    pub attack: String,
    /// Byzantine robots.
    pub count: u32,
    /// Its runs, in seed order.
    pub runs: Vec<Run>,
}

impl Cell {
    /// The mean over the runs of the final loss as a fraction of genesis.
    pub fn mean(&self) -> Option<f64> {
        (!self.runs.is_empty())
            .then(|| self.runs.iter().map(Run::fraction).sum::<f64>() / self.runs.len() as f64)
    }

    /// The runs' fractions, ascending.
    pub fn sorted(&self) -> Vec<f64> {
        let mut f: Vec<f64> = self.runs.iter().map(Run::fraction).collect();
        f.sort_by(f64::total_cmp);
        f
    }
}

/// The benchmark read from the results: its axes in grid order and its cells.
#[derive(Clone, Debug, Default)]
pub struct Hetero {
    /// The experiment.
    pub experiment: String,
    /// The alphas, roaming first (grid order).
    pub alphas: Vec<String>,
    /// The rules, grid order.
    pub rules: Vec<String>,
    /// The Byzantine counts, ascending.
    pub counts: Vec<u32>,
    /// The cells, grid order.
    pub cells: Vec<Cell>,
    /// Runs left out: no genesis or no final held-out loss in their summary.
    pub unread: usize,
}

/// The final held-out loss of a run: the summary's own, else the last aggregation's; `None`
/// when it has neither (a run that aggregated nothing). Not finite counts as infinite.
fn last_heldout(summary: &Summary) -> Option<f64> {
    let c = &summary.run.contract;
    let v = c
        .final_heldout_loss
        .or_else(|| c.heldout_loss_by_round.last().copied())?;
    Some(if v.is_finite() { v } else { f64::INFINITY })
}

/// Reads the results of `experiment` (`None` when it is not built in or has none).
pub fn study(results: &[RunResult], experiment: &str) -> Option<Hetero> {
    let grid = experiments::experiment(experiment).ok()?;
    let mut h = Hetero {
        experiment: experiment.to_string(),
        ..Hetero::default()
    };
    for r in results.iter().filter(|r| r.experiment == experiment) {
        let Some(point) = grid.points.iter().find(|p| p.name == r.point) else {
            continue;
        };
        let (Some(alpha), Some(rule), Some(attack)) =
            (point.tag("alpha"), point.tag("rule"), point.tag("attack"))
        else {
            continue;
        };
        let genesis = r.result.summary.run.contract.heldout_loss_initial;
        let last = last_heldout(&r.result.summary);
        let (Some(last), true) = (last, genesis.is_finite() && genesis > 0.0) else {
            h.unread += 1;
            continue;
        };
        let count = point.x as u32;
        let c = &r.result.summary.run.contract;
        let submitted = |k: &str| c.submissions.get(k).copied().unwrap_or(0);
        let run = Run {
            seed: r.seed,
            genesis,
            last,
            outliers: submitted("outlier"),
            counted: submitted("accepted") + submitted("aggregated") + submitted("outlier"),
            honest_distance: c.mean_honest_distance,
            honest_distance_max_round: c
                .mean_honest_distance_by_round
                .iter()
                .copied()
                .filter(|d| d.is_finite())
                .max_by(f64::total_cmp),
            threshold: c.outlier_threshold,
        };
        let same =
            |c: &Cell| c.alpha == alpha && c.rule == rule && c.attack == attack && c.count == count;
        match h.cells.iter().position(same) {
            Some(at) => h.cells[at].runs.push(run),
            None => h.cells.push(Cell {
                alpha,
                rule,
                attack,
                count,
                runs: vec![run],
            }),
        }
    }
    if h.cells.is_empty() {
        return None;
    }
    h.axes(&grid.points);
    Some(h)
}

/// The worst case over the attacks of one rule, alpha and count.
#[derive(Clone, Debug, PartialEq)]
pub struct Worst<'a> {
    /// The attack's cell.
    pub cell: &'a Cell,
    /// Its mean fraction of genesis.
    pub mean: f64,
}

impl Hetero {
    /// The axes in the grid's order (not the results'), each value once.
    fn axes(&mut self, points: &[experiments::Point]) {
        for p in points {
            let (Some(alpha), Some(rule)) = (p.tag("alpha"), p.tag("rule")) else {
                continue;
            };
            let count = p.x as u32;
            let held = |c: &Cell| c.alpha == alpha && c.rule == rule && c.count == count;
            if !self.cells.iter().any(held) {
                continue;
            }
            if !self.alphas.contains(&alpha) {
                self.alphas.push(alpha);
            }
            if !self.rules.contains(&rule) {
                self.rules.push(rule);
            }
            if !self.counts.contains(&count) {
                self.counts.push(count);
            }
        }
        self.counts.sort_unstable();
        for c in &mut self.cells {
            c.runs.sort_by_key(|r| r.seed);
        }
    }

    /// The cells of one rule, alpha and count (one per attack), in grid order.
    pub fn of(&self, rule: &str, alpha: &str, count: u32) -> Vec<&Cell> {
        self.cells
            .iter()
            .filter(|c| c.rule == rule && c.alpha == alpha && c.count == count)
            .collect()
    }

    /// The worst case over the attacks (highest mean fraction, ties to the earlier attack).
    pub fn worst(&self, rule: &str, alpha: &str, count: u32) -> Option<Worst<'_>> {
        self.of(rule, alpha, count)
            .into_iter()
            .filter_map(|c| c.mean().map(|mean| Worst { cell: c, mean }))
            .fold(None, |best: Option<Worst<'_>>, w| match best {
                Some(b) if b.mean >= w.mean => Some(b),
                _ => Some(w),
            })
    }

    /// Destroyed runs and runs over every attack and seed of one rule, alpha and count.
    pub fn destroyed(&self, rule: &str, alpha: &str, count: u32) -> (usize, usize) {
        self.of(rule, alpha, count)
            .into_iter()
            .flat_map(|c| &c.runs)
            .fold((0, 0), |(k, n), r| (k + usize::from(r.destroyed()), n + 1))
    }

    /// The seeds the results hold, ascending.
    pub fn seeds(&self) -> Vec<u64> {
        let mut seeds: Vec<u64> = self
            .cells
            .iter()
            .flat_map(|c| c.runs.iter().map(|r| r.seed))
            .collect();
        seeds.sort_unstable();
        seeds.dedup();
        seeds
    }

    /// The colour scale every map shares: the worst cases' range, its top clipped at the
    /// 95th percentile or at 1 (the genesis model's loss), the lower.
    fn scale(&self) -> Scale {
        let all = self.rules.iter().flat_map(|r| {
            self.alphas.iter().flat_map(move |a| {
                self.counts
                    .iter()
                    .filter_map(move |&c| self.worst(r, a, c).map(|w| w.mean))
            })
        });
        let mut scale = Scale::of(all, false);
        if scale.lo < 1.0 && scale.hi > 1.0 {
            scale.hi = 1.0;
            scale.clipped = true;
            scale.clipped_at = Some("1, the genesis model's loss (a model that learned nothing)");
        }
        scale
    }
}

/// A column name: `alpha inf` (roaming), `alpha 0.1`.
fn column(alpha: &str) -> String {
    if alpha == "inf" {
        "inf (roaming)".to_string()
    } else {
        alpha.to_string()
    }
}

/// Per Byzantine count, the heatmap of rule x alpha of the worst case over the attacks, each
/// attacked cell labelled with its destroyed runs; drawn into `out`.
fn draw_maps(h: &Hetero, out: &Path, notes: &mut Vec<String>) -> anyhow::Result<Vec<Figure>> {
    let name = &h.experiment;
    let shared = h.scale();
    let mut figures = Vec::new();
    for &count in &h.counts {
        let stem = format!("{name}-byzantine-{count}");
        let what = if count == 0 {
            "no Byzantine robot (the clean runs)".to_string()
        } else {
            format!("{count} Byzantine robots of 15, worst case over the attacks")
        };
        let map = Heatmap {
            title: format!("{name}: {what}"),
            row_title: "rule".to_string(),
            col_title: "home-range alpha (low: robots keep to few regions)".to_string(),
            value_title: "final held-out loss / genesis (mean over seeds, log scale)".to_string(),
            rows: h.rules.clone(),
            cols: h.alphas.iter().map(|a| column(a)).collect(),
            values: h
                .rules
                .iter()
                .map(|r| {
                    h.alphas
                        .iter()
                        .map(|a| h.worst(r, a, count).map(|w| w.mean))
                        .collect()
                })
                .collect(),
            diverging: false,
            labels: h
                .rules
                .iter()
                .map(|r| {
                    h.alphas
                        .iter()
                        .map(|a| match h.destroyed(r, a, count) {
                            (_, 0) => String::new(),
                            (k, n) => format!("{k}/{n} destroyed"),
                        })
                        .collect()
                })
                .collect(),
            shared_scale: Some(shared),
        };
        if map.values.iter().flatten().all(Option::is_none) {
            continue;
        }
        if !draw(&map, out, &stem)? {
            notes.push(format!(
                "no font could be loaded: {stem} drawn without text"
            ));
        }
        figures.push(Figure {
            experiment: name.clone(),
            stem,
            caption: format!(
                "{name}: {what}: final held-out loss as a fraction of each run's genesis \
                 model's (1 = learned nothing), per rule (rows) and home-range alpha \
                 (columns); labels: runs whose model was destroyed (final loss above genesis) \
                 over every attack and seed; one colour scale for every count"
            ),
        });
    }
    Ok(figures)
}

#[cfg(test)]
mod tests;

//! `e4-benchmark` (issue #33): the robustness benchmark in the form ByzFL reports it. Per rule
//! a heatmap of the worst-case final held-out loss over the attacks, Byzantine count against
//! data heterogeneity (the swarm's behaviour, ordered by the motion heterogeneity,
//! `world.data_heterogeneity`, its clean runs measured); an aggregated heatmap of the best rule per cell; and the worst-case table.
//!
//! Worst case, per rule, behaviour and count: the attack whose mean final held-out loss over
//! the runs is highest (ties to the earlier attack in grid order); at count 0 the clean run's.
//! Best rule per cell: the lowest worst case (ties to the earlier rule in grid order). Every
//! rule's map shares one colour scale, so the maps compare by colour. Its top is the 95th
//! percentile of all their cells (see `heatmap`) or the genesis model's held-out loss, the
//! lower: a model at or above the untrained one learned nothing, and a rule the attack blew
//! up (a loss of 1e10) would otherwise wash every other cell out to white.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use crate::summary::Summary;

use super::heatmap::{draw, Heatmap, Scale};
use super::load::RunResult;
use super::markdown;
use super::plots::Figure;
use super::stats::{fixed, ExperimentStats};
use super::study::{drawn_by, Drawn, Section, StudyReport};
use crate::experiments::{self, DrawnBy, Entry};

/// The study report of the experiments drawn by [`DrawnBy::Benchmark`].
#[derive(Debug)]
pub struct Benchmark;

impl StudyReport for Benchmark {
    fn draws(&self, entry: Option<&Entry>) -> bool {
        entry.is_some_and(|e| e.drawn_by == DrawnBy::Benchmark)
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
            let Some(b) = study(results, &e.name) else {
                continue;
            };
            drawn.figures.extend(draw_all(&b, out, notes)?);
            let (text, csv) = tables(&b);
            drawn
                .files
                .push((format!("{}-worst-case.csv", b.experiment), csv));
            drawn.sections.push(Section {
                experiment: e.name.clone(),
                text,
            });
        }
        Ok(drawn)
    }
}

/// One point's runs.
#[derive(Clone, Debug)]
struct Cell {
    behaviour: String,
    rule: String,
    attack: String,
    count: u32,
    /// Final held-out loss per run, in seed order.
    losses: Vec<f64>,
}

impl Cell {
    fn loss(&self) -> Option<f64> {
        (!self.losses.is_empty())
            .then(|| self.losses.iter().sum::<f64>() / self.losses.len() as f64)
    }
}

/// A behaviour of the heterogeneity axis and what its clean runs measured.
#[derive(Clone, Debug)]
pub struct Level {
    /// The behaviour.
    pub behaviour: String,
    /// Mean motion heterogeneity (`world.data_heterogeneity`) over its clean runs.
    pub heterogeneity: Option<f64>,
    /// Those runs.
    pub runs: usize,
}

/// One cell of the worst-case table.
#[derive(Clone, Debug, PartialEq)]
pub struct Worst {
    /// The rule (`nnm+` when behind NNM).
    pub rule: String,
    /// The behaviour.
    pub behaviour: String,
    /// Byzantine robots.
    pub count: u32,
    /// The rule's clean loss in that swarm.
    pub clean: Option<f64>,
    /// The worst attack (`none` at count 0) and its mean loss.
    pub attack: String,
    /// Its mean final held-out loss.
    pub loss: f64,
    /// The fewest runs among the cell's attacks.
    pub runs: usize,
}

/// The benchmark read from the results.
#[derive(Clone, Debug, Default)]
pub struct Bench {
    /// The experiment.
    pub experiment: String,
    /// The heterogeneity axis, least heterogeneous first.
    pub levels: Vec<Level>,
    /// The rules in grid order.
    pub rules: Vec<String>,
    /// The Byzantine counts, ascending (0 first).
    pub counts: Vec<u32>,
    /// Per rule, behaviour and count, the worst case.
    pub worst: Vec<Worst>,
    /// Mean held-out loss of the genesis model over the runs (`heldout_loss_initial`).
    pub genesis: Option<f64>,
}

/// The final held-out loss of a run: the summary's own, else the last aggregation's.
fn final_heldout(summary: &Summary) -> Option<f64> {
    let c = &summary.run.contract;
    c.final_heldout_loss
        .or_else(|| c.heldout_loss_by_round.last().copied())
        .filter(|v| v.is_finite())
}

/// Reads the results of the benchmark `experiment` (`None` when there are none).
pub fn study(results: &[RunResult], experiment: &str) -> Option<Bench> {
    let read = read(results, experiment)?;
    if read.cells.is_empty() {
        return None;
    }
    let mut bench = Bench {
        experiment: experiment.to_string(),
        genesis: mean(&read.genesis),
        ..Bench::default()
    };
    bench.axes(&read);
    bench.worst_cases(&read.cells);
    Some(bench)
}

/// What the results of the benchmark hold: its cells, the heterogeneity each behaviour's
/// clean runs measured, and the genesis model's held-out loss of each run.
#[derive(Default)]
struct Read {
    cells: Vec<Cell>,
    measured: BTreeMap<String, Vec<f64>>,
    genesis: Vec<f64>,
}

/// The mean of `values` (`None` for none).
fn mean(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

/// Reads the cells of `experiment`'s results (`None` when it is not built in).
fn read(results: &[RunResult], experiment: &str) -> Option<Read> {
    let grid = experiments::experiment(experiment).ok()?;
    let mut read = Read::default();
    for r in results.iter().filter(|r| r.experiment == experiment) {
        let Some(point) = grid.points.iter().find(|p| p.name == r.point) else {
            continue;
        };
        let (Some(behaviour), Some(rule), Some(attack)) = (
            point.tag("behaviour"),
            point.tag("rule"),
            point.tag("attack"),
        ) else {
            continue;
        };
        let count = point.x as u32;
        let run = &r.result.summary.run;
        if let Some(g) = Some(run.contract.heldout_loss_initial).filter(|g| g.is_finite()) {
            read.genesis.push(g);
        }
        // JSON holds NaN as `null`: a run without the measure does not count.
        if let Some(h) = Some(run.world.data_heterogeneity).filter(|h| !h.is_nan()) {
            if count == 0 {
                read.measured.entry(behaviour.clone()).or_default().push(h);
            }
        }
        // Results come sorted by point and seed (`load`); found by key all the same, so the
        // cells do not depend on that order.
        let same = |c: &&mut Cell| {
            c.behaviour == behaviour && c.rule == rule && c.attack == attack && c.count == count
        };
        let at = match read.cells.iter_mut().position(|c| same(&c)) {
            Some(at) => at,
            None => {
                read.cells.push(Cell {
                    behaviour,
                    rule,
                    attack,
                    count,
                    losses: Vec::new(),
                });
                read.cells.len() - 1
            }
        };
        if let Some(loss) = final_heldout(&r.result.summary) {
            read.cells[at].losses.push(loss);
        }
    }
    Some(read)
}

impl Bench {
    /// The axes in grid order, the levels then sorted by what they measured.
    fn axes(&mut self, read: &Read) {
        for c in &read.cells {
            if !self.levels.iter().any(|l| l.behaviour == c.behaviour) {
                let measured = read.measured.get(&c.behaviour);
                self.levels.push(Level {
                    behaviour: c.behaviour.clone(),
                    heterogeneity: measured.and_then(|v| mean(v)),
                    runs: measured.map_or(0, Vec::len),
                });
            }
            if !self.rules.contains(&c.rule) {
                self.rules.push(c.rule.clone());
            }
            if !self.counts.contains(&c.count) {
                self.counts.push(c.count);
            }
        }
        self.counts.sort_unstable();
        self.levels.sort_by(|a, b| {
            a.heterogeneity
                .unwrap_or(f64::INFINITY)
                .total_cmp(&b.heterogeneity.unwrap_or(f64::INFINITY))
        });
    }

    /// Per rule, level and count, the worst case of `cells`.
    fn worst_cases(&mut self, cells: &[Cell]) {
        for rule in &self.rules {
            for level in &self.levels {
                let of = |count: u32| {
                    cells.iter().filter(move |c| {
                        &c.rule == rule && c.behaviour == level.behaviour && c.count == count
                    })
                };
                let clean = of(0).find_map(Cell::loss);
                for &count in &self.counts {
                    let runs = of(count).map(|c| c.losses.len()).min().unwrap_or(0);
                    let worst = of(count).filter_map(|c| c.loss().map(|l| (c, l))).fold(
                        None::<(&Cell, f64)>,
                        |best, (c, l)| match best {
                            Some((_, b)) if b >= l => best,
                            _ => Some((c, l)),
                        },
                    );
                    if let Some((c, loss)) = worst {
                        self.worst.push(Worst {
                            rule: rule.clone(),
                            behaviour: level.behaviour.clone(),
                            count,
                            clean,
                            attack: c.attack.clone(),
                            loss,
                            runs,
                        });
                    }
                }
            }
        }
    }
}

impl Bench {
    /// The colour scale every map shares: the worst cases' range, its top clipped at the
    /// 95th percentile or the genesis model's loss, the lower.
    fn scale(&self) -> Scale {
        let mut scale = Scale::of(self.worst.iter().map(|w| w.loss), false);
        if let Some(g) = self.genesis.filter(|&g| g > scale.lo && g < scale.hi) {
            scale.hi = g;
            scale.clipped = true;
            scale.clipped_at =
                Some("the genesis model's held-out loss (a model that learned nothing)");
        }
        scale
    }

    fn worst_of(&self, rule: &str, behaviour: &str, count: u32) -> Option<&Worst> {
        self.worst
            .iter()
            .find(|w| w.rule == rule && w.behaviour == behaviour && w.count == count)
    }

    /// The rule with the lowest worst case in a cell (ties to the earlier rule).
    fn best(&self, behaviour: &str, count: u32) -> Option<&Worst> {
        self.rules
            .iter()
            .filter_map(|r| self.worst_of(r, behaviour, count))
            .fold(None::<&Worst>, |best, w| match best {
                Some(b) if b.loss <= w.loss => Some(b),
                _ => Some(w),
            })
    }

    /// A column name: the behaviour and its measured heterogeneity.
    fn column(level: &Level) -> String {
        match level.heterogeneity {
            Some(h) => format!("{} (V {h:.3})", level.behaviour),
            None => level.behaviour.clone(),
        }
    }

    fn row(count: u32) -> String {
        if count == 0 {
            "0 (clean)".to_string()
        } else {
            count.to_string()
        }
    }
}

/// Draws the per-rule and the aggregated heatmaps into `out` and returns them.
fn draw_all(b: &Bench, out: &Path, notes: &mut Vec<String>) -> anyhow::Result<Vec<Figure>> {
    let mut figures = Vec::new();
    let name = &b.experiment;
    let cols: Vec<String> = b.levels.iter().map(Bench::column).collect();
    let rows: Vec<String> = b.counts.iter().map(|&c| Bench::row(c)).collect();
    let shared = b.scale();
    let col_title = "swarm behaviour (V: its motion heterogeneity)";
    let value_title = "worst-case final held-out loss over the attacks (log scale)";
    let mut maps: Vec<(String, String, Heatmap)> = Vec::new();
    for rule in &b.rules {
        maps.push((
            format!("{name}-{rule}"),
            format!(
                "{name}: {rule}, worst-case final held-out loss over the attacks per \
                 Byzantine count (rows) and swarm behaviour (columns); row 0 is the clean run \
                 (mean over runs; one colour scale for every rule)"
            ),
            Heatmap {
                title: format!("{name}: {rule}, worst case over attacks"),
                row_title: "Byzantine robots of 15".to_string(),
                col_title: col_title.to_string(),
                value_title: value_title.to_string(),
                rows: rows.clone(),
                cols: cols.clone(),
                values: b
                    .counts
                    .iter()
                    .map(|&c| {
                        b.levels
                            .iter()
                            .map(|l| b.worst_of(rule, &l.behaviour, c).map(|w| w.loss))
                            .collect()
                    })
                    .collect(),
                diverging: false,
                labels: Vec::new(),
                shared_scale: Some(shared),
            },
        ));
    }
    let best: Vec<Vec<Option<&Worst>>> = b
        .counts
        .iter()
        .map(|&c| b.levels.iter().map(|l| b.best(&l.behaviour, c)).collect())
        .collect();
    maps.push((
        format!("{name}-best"),
        format!(
            "{name}: the best rule per cell (lowest worst-case final held-out loss over \
             the attacks) and that loss, per Byzantine count and swarm behaviour"
        ),
        Heatmap {
            title: format!("{name}: best rule per cell"),
            row_title: "Byzantine robots of 15".to_string(),
            col_title: col_title.to_string(),
            value_title: "the best rule's worst-case final held-out loss (log scale)".to_string(),
            rows,
            cols,
            values: best
                .iter()
                .map(|r| r.iter().map(|w| w.map(|w| w.loss)).collect())
                .collect(),
            diverging: false,
            labels: best
                .iter()
                .map(|r| {
                    r.iter()
                        .map(|w| w.map_or_else(String::new, |w| w.rule.clone()))
                        .collect()
                })
                .collect(),
            shared_scale: Some(shared),
        },
    ));
    for (stem, caption, map) in maps {
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
            caption,
        });
    }
    Ok(figures)
}

/// The report's section: the axis, the best rule per cell and the worst-case table (markdown),
/// and `e4-benchmark-worst-case.csv`.
fn tables(b: &Bench) -> (String, String) {
    let name = &b.experiment;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Heterogeneity axis (mean motion heterogeneity, `world.data_heterogeneity`, of the clean runs, runs):"
    );
    for l in &b.levels {
        let _ = writeln!(
            md,
            "- {}: {} ({} runs)",
            l.behaviour,
            l.heterogeneity
                .map_or_else(|| "n/a".to_string(), |h| fixed(h, 4)),
            l.runs
        );
    }
    let _ = writeln!(
        md,
        "\nBest rule per cell (lowest worst-case final held-out loss over the attacks):\n"
    );
    let mut columns = vec!["Byzantine robots".to_string()];
    columns.extend(b.levels.iter().map(Bench::column));
    markdown::header(&mut md, &columns);
    for &count in &b.counts {
        let _ = write!(md, "| {} |", Bench::row(count));
        for l in &b.levels {
            match b.best(&l.behaviour, count) {
                Some(w) => {
                    let _ = write!(md, " {} ({}) |", w.rule, fixed(w.loss, 5));
                }
                None => {
                    let _ = write!(md, " n/a |");
                }
            }
        }
        let _ = writeln!(md);
    }
    let attacked: Vec<u32> = b.counts.iter().copied().filter(|&c| c > 0).collect();
    let _ = writeln!(
        md,
        "\nWorst case per rule and swarm: the attack with the highest mean final held-out loss \
         at each Byzantine count, its loss and that loss as a multiple of the rule's clean run \
         in the same swarm (`{name}-worst-case.csv`).\n"
    );
    let mut columns: Vec<String> = ["rule", "swarm", "clean loss"].map(String::from).into();
    columns.extend(
        attacked
            .iter()
            .map(|c| format!("worst attack, {c} Byzantine (loss, x clean)")),
    );
    markdown::header(&mut md, &columns);
    let mut csv = String::from(
        "rule,behaviour,heterogeneity,count,clean_loss,worst_attack,worst_loss,ratio,runs\n",
    );
    let number = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{v:e}"));
    for rule in &b.rules {
        for l in &b.levels {
            let clean = b.worst_of(rule, &l.behaviour, 0).map(|w| w.loss);
            let _ = write!(
                md,
                "| {rule} | {} | {} |",
                l.behaviour,
                clean.map_or_else(|| "n/a".to_string(), |c| fixed(c, 5))
            );
            for &count in &b.counts {
                let Some(w) = b.worst_of(rule, &l.behaviour, count) else {
                    if count > 0 {
                        let _ = write!(md, " n/a |");
                    }
                    continue;
                };
                let ratio = w.clean.filter(|&c| c > 0.0).map(|c| w.loss / c);
                let _ = writeln!(
                    csv,
                    "{rule},{},{},{count},{},{},{:e},{},{}",
                    l.behaviour,
                    number(l.heterogeneity),
                    number(w.clean),
                    w.attack,
                    w.loss,
                    number(ratio),
                    w.runs
                );
                if count > 0 {
                    let _ = write!(
                        md,
                        " {} ({}, {}) |",
                        w.attack,
                        fixed(w.loss, 5),
                        ratio.map_or_else(|| "n/a".to_string(), |r| format!("{r:.2}x"))
                    );
                }
            }
            let _ = writeln!(md);
        }
    }
    (md, csv)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The experiment the benchmark draws.
    fn experiment() -> &'static str {
        let entry = experiments::ALL.iter().find(|e| Benchmark.draws(Some(e)));
        entry.expect("an experiment drawn by the benchmark").name()
    }

    /// A run with the final held-out loss `loss` and the data heterogeneity `heterogeneity`
    /// (every other figure a reduced-study run's, without the genesis model's loss).
    fn result(point: &str, seed: u64, loss: f64, heterogeneity: f64) -> RunResult {
        let mut result = crate::summary::tests::example();
        let run = &mut result.summary.run;
        run.contract.final_heldout_loss = Some(loss);
        run.contract.heldout_loss_initial = f64::NAN;
        run.world.data_heterogeneity = heterogeneity;
        RunResult {
            experiment: experiment().to_string(),
            point: point.to_string(),
            seed,
            result,
        }
    }

    /// Worst case over attacks, best rule per cell and the axis order, by hand (values chosen
    /// exact in binary, so the sums are too).
    #[test]
    fn worst_cases_best_rules_and_the_axis_order_match_hand_computed_cells() {
        // Two behaviours x two rules; the mixed swarm measures less heterogeneity here, so it
        // comes first whatever the grid order.
        let mut results = Vec::new();
        for (behaviour, h) in [("flocking", 0.375), ("mixed", 0.125)] {
            for (rule, clean, alie, ipm) in
                [("median", 0.125, 0.5, 0.25), ("krum", 0.25, 0.375, 0.75)]
            {
                for seed in [1, 2] {
                    // Seed 2 doubles every loss: the means are 1.5x seed 1's.
                    let k = seed as f64;
                    let point = |attack: &str, count: u32| {
                        format!("{behaviour}--{rule}--{attack}--{count}")
                    };
                    results.push(result(&point("none", 0), seed, clean * k, h));
                    results.push(result(&point("optimal-alie", 3), seed, alie * k, h));
                    results.push(result(&point("optimal-ipm", 3), seed, ipm * k, h));
                }
            }
        }
        let b = study(&results, experiment()).unwrap();
        assert_eq!(
            b.levels
                .iter()
                .map(|l| l.behaviour.as_str())
                .collect::<Vec<_>>(),
            ["mixed", "flocking"]
        );
        assert_eq!(b.levels[0].heterogeneity, Some(0.125));
        assert_eq!(b.levels[0].runs, 4);
        assert_eq!(b.rules, ["median", "krum"]);
        assert_eq!(b.counts, [0, 3]);
        let w = b.worst_of("median", "mixed", 3).unwrap();
        assert_eq!(
            (w.attack.as_str(), w.loss, w.clean, w.runs),
            ("optimal-alie", 0.75, Some(0.1875), 2)
        );
        assert_eq!(
            b.worst_of("krum", "mixed", 3).unwrap().attack,
            "optimal-ipm"
        );
        // Best per cell: clean, median (0.1875 < 0.375); attacked, median (0.75 < 1.125).
        assert_eq!(b.best("mixed", 0).unwrap().rule, "median");
        assert_eq!(b.best("mixed", 3).unwrap().rule, "median");
        let (md, csv) = tables(&b);
        assert!(
            md.contains("| 3 | median (0.75000) | median (0.75000) |"),
            "{md}"
        );
        assert!(
            md.contains("| krum | mixed | 0.37500 | optimal-ipm (1.12500, 3.00x) |"),
            "{md}"
        );
        assert_eq!(csv.lines().count(), 1 + 2 * 2 * 2);
        assert!(
            csv.contains("median,mixed,1.25e-1,3,1.875e-1,optimal-alie,7.5e-1,4e0,2"),
            "{csv}"
        );
    }
}

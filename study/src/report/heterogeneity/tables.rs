//! The heterogeneity benchmark's tables: `report.md`'s section and its two CSV files.

use std::fmt::Write as _;

use super::{column, Cell, Hetero};
use crate::report::markdown;
use crate::report::stats::{fixed, wilson};

/// A clean FedAvg run "learned" when its final held-out loss is at most this fraction of its
/// genesis model's (it halved the untrained model's loss).
pub const LEARNED: f64 = 0.5;

/// A fraction of genesis for tables: 4 significant digits, or `destroyed (1.2e9)` style
/// scientific for the huge ones.
fn frac(v: f64) -> String {
    if !v.is_finite() {
        "inf".to_string()
    } else if v >= 1000.0 || (v > 0.0 && v < 1e-3) {
        format!("{v:.2e}")
    } else {
        fixed(v, 4)
    }
}

/// `k/n [lo-hi %]` with the Wilson interval.
fn share(k: usize, n: usize) -> String {
    let (lo, hi) = wilson(k, n);
    format!("{k}/{n} [{:.0}-{:.0} %]", lo * 100.0, hi * 100.0)
}

/// The median of ascending `sorted` (mean of the middle two when even).
fn median(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
    }
}

/// `min / median / max` of a cell's fractions.
fn spread(cell: &Cell) -> String {
    let s = cell.sorted();
    match (s.first(), s.last()) {
        (Some(&lo), Some(&hi)) => format!("{} / {} / {}", frac(lo), frac(median(&s)), frac(hi)),
        _ => "n/a".to_string(),
    }
}

/// The attacked counts of the results.
fn attacked(h: &Hetero) -> Vec<u32> {
    h.counts.iter().copied().filter(|&c| c > 0).collect()
}

/// `report.md`'s section.
pub(super) fn markdown(h: &Hetero) -> String {
    let mut md = String::new();
    let runs: usize = h.cells.iter().map(|c| c.runs.len()).sum();
    let seeds = h.seeds();
    let _ = writeln!(
        md,
        "{runs} runs read, seeds {}. Every loss below is the run's final held-out loss as a \
         fraction of its own genesis model's (alpha changes the task); a run is destroyed when \
         that fraction is above 1.{}\n",
        seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(", "),
        if h.unread > 0 {
            format!(
                " {} runs without a genesis or final held-out loss are left out.",
                h.unread
            )
        } else {
            String::new()
        }
    );
    clean_fedavg(&mut md, h);
    threshold_table(&mut md, h);
    destroyed_table(&mut md, h);
    worst_table(&mut md, h);
    per_seed_table(&mut md, h);
    md
}

/// Does a clean FedAvg still learn as alpha falls? Per alpha its genesis loss and final
/// fraction, and a sentence on the lowest alpha and on where learning stops.
fn clean_fedavg(md: &mut String, h: &Hetero) {
    let _ = writeln!(
        md,
        "### Does a clean FedAvg still learn?\n\nFedAvg without Byzantine robots per alpha: the \
         genesis model's held-out loss (median over seeds) and the final loss as a fraction of \
         it; learned: the seeds that ended at or below {LEARNED} of genesis.\n"
    );
    let clean: Vec<(&String, &Cell)> = h
        .alphas
        .iter()
        .filter_map(|a| h.of("fedavg", a, 0).first().map(|&c| (a, c)))
        .collect();
    if clean.is_empty() {
        let _ = writeln!(md, "No clean FedAvg run in the results.\n");
        return;
    }
    let columns = [
        "alpha",
        "genesis loss",
        "final / genesis (min / median / max)",
        "learned",
    ];
    markdown::header(md, &columns.map(String::from));
    let mut stops = None;
    let mut lowest = None;
    for (a, cell) in clean {
        let mut genesis: Vec<f64> = cell.runs.iter().map(|r| r.genesis).collect();
        genesis.sort_by(f64::total_cmp);
        let sorted = cell.sorted();
        let learned = sorted.iter().filter(|&&f| f <= LEARNED).count();
        let _ = writeln!(
            md,
            "| {} | {} | {} | {learned} of {} |",
            column(a),
            fixed(median(&genesis), 3),
            spread(cell),
            sorted.len()
        );
        if stops.is_none() && median(&sorted) > LEARNED {
            stops = Some(a.clone());
        }
        lowest = Some((a.clone(), median(&sorted), learned, sorted.len()));
    }
    let Some((a, m, learned, n)) = lowest else {
        return;
    };
    let verdict = match learned {
        k if k == n => "it still learns".to_string(),
        0 => "it does not learn".to_string(),
        k => format!("it learns on {k} of {n} seeds"),
    };
    let _ = writeln!(
        md,
        "\nAt the lowest alpha ({a}) a clean FedAvg run ends at {} of its genesis held-out loss \
         (median of {n} seeds): {verdict}. {}\n",
        frac(m),
        match stops {
            Some(s) =>
                format!("Learning stops (median above {LEARNED} of genesis) from alpha {s} on."),
            None => format!("At no alpha does the median run end above {LEARNED} of genesis."),
        }
    );
}

/// The rules that judge every submission by the paper's absolute distance threshold
/// (`contract.outlier_threshold`): the paper's rule, and its gate before the median.
pub const THRESHOLD_RULES: [&str; 2] = ["paper", "gate+median"];

/// Does the paper's absolute threshold start rejecting honest robots as their data grow apart?
/// Per threshold rule and alpha, from the clean runs (every robot honest, so every outlier is
/// an honest robot's): the submissions judged outliers, the honest submissions' mean distance
/// to the shared model and its largest round mean, beside the threshold.
fn threshold_table(md: &mut String, h: &Hetero) {
    let cells: Vec<&Cell> = THRESHOLD_RULES
        .iter()
        .flat_map(|rule| h.alphas.iter().flat_map(move |a| h.of(rule, a, 0)))
        .filter(|c| !c.runs.is_empty())
        .collect();
    if cells.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "### Does the paper's threshold reject honest robots?\n\nThe rules that judge every \
         submission by one absolute distance (the mean absolute difference per weight from the \
         shared model, against `contract.outlier_threshold`), in the clean runs, where every \
         robot is honest: the submissions judged outliers of those counted (every seed), the \
         honest submissions' mean distance (min / median / max over the seeds) and the largest \
         mean of one round (over every seed).\n"
    );
    let columns = [
        "rule",
        "alpha",
        "outliers / counted",
        "mean distance (min / median / max)",
        "largest round mean",
        "threshold",
    ];
    markdown::header(md, &columns.map(String::from));
    let (mut outliers, mut counted, mut largest) = (0, 0, 0.0f64);
    let mut threshold = f64::INFINITY;
    for cell in &cells {
        let o: u64 = cell.runs.iter().map(|r| r.outliers).sum();
        let n: u64 = cell.runs.iter().map(|r| r.counted).sum();
        let mut d: Vec<f64> = cell.runs.iter().filter_map(|r| r.honest_distance).collect();
        d.sort_by(f64::total_cmp);
        let max_round = cell
            .runs
            .iter()
            .filter_map(|r| r.honest_distance_max_round)
            .max_by(f64::total_cmp);
        let t = cell
            .runs
            .iter()
            .map(|r| r.threshold)
            .fold(f64::INFINITY, f64::min);
        let spread = match (d.first(), d.last()) {
            (Some(&lo), Some(&hi)) => {
                format!(
                    "{} / {} / {}",
                    fixed(lo, 4),
                    fixed(median(&d), 4),
                    fixed(hi, 4)
                )
            }
            _ => "n/a".to_string(),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {o} / {n} | {spread} | {} | {} |",
            cell.rule,
            column(&cell.alpha),
            max_round.map_or("n/a".to_string(), |m| fixed(m, 4)),
            fixed(t, 4)
        );
        outliers += o;
        counted += n;
        largest = largest.max(max_round.unwrap_or(0.0));
        threshold = threshold.min(t);
    }
    let verdict = if outliers == 0 {
        "none".to_string()
    } else {
        format!(
            "{outliers} ({} %)",
            fixed(100.0 * outliers as f64 / counted as f64, 2)
        )
    };
    let _ = writeln!(
        md,
        "\nOf {counted} honest submissions in these clean runs, the threshold rejected \
         {verdict}. The largest round mean of the honest distances, {}, is {} of the threshold \
         ({}).\n",
        fixed(largest, 4),
        fixed(largest / threshold, 3),
        fixed(threshold, 4)
    );
}

/// Destroyed runs per rule, alpha and attacked count, over every attack and seed, with the
/// 95 % Wilson interval.
fn destroyed_table(md: &mut String, h: &Hetero) {
    let _ = writeln!(
        md,
        "### Destroyed runs\n\nRuns whose final held-out loss is above the genesis model's, of \
         every attack and seed per cell, with the 95 % Wilson interval of the share.\n"
    );
    let mut columns = vec!["rule".to_string()];
    for &c in &attacked(h) {
        columns.extend(h.alphas.iter().map(|a| format!("{c} Byz, alpha {a}")));
    }
    markdown::header(md, &columns);
    for rule in &h.rules {
        let _ = write!(md, "| {rule} |");
        for &c in &attacked(h) {
            for a in &h.alphas {
                let (k, n) = h.destroyed(rule, a, c);
                let _ = write!(md, " {} |", if n == 0 { "n/a".into() } else { share(k, n) });
            }
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(md);
}

/// The worst case over the attacks per rule and alpha at each count, with the per-seed spread
/// of that attack.
fn worst_table(md: &mut String, h: &Hetero) {
    let _ = writeln!(
        md,
        "### Worst case over the attacks, and its spread over the seeds\n\nPer rule, alpha and \
         Byzantine count: the attack with the highest mean final / genesis over the seeds, that \
         mean, and the attack's min / median / max over the seeds (`{}-cells.csv`).\n",
        h.experiment
    );
    let mut columns = vec!["rule".to_string(), "alpha".to_string()];
    columns.extend(h.counts.iter().map(|&c| match c {
        0 => "clean: mean (min / median / max)".to_string(),
        c => format!("{c} Byzantine: worst attack, mean (min / median / max)"),
    }));
    markdown::header(md, &columns);
    for rule in &h.rules {
        for a in &h.alphas {
            let _ = write!(md, "| {rule} | {} |", column(a));
            for &c in &h.counts {
                match h.worst(rule, a, c) {
                    Some(w) if c == 0 => {
                        let _ = write!(md, " {} ({}) |", frac(w.mean), spread(w.cell));
                    }
                    Some(w) => {
                        let _ = write!(
                            md,
                            " {}, {} ({}) |",
                            w.cell.attack,
                            frac(w.mean),
                            spread(w.cell)
                        );
                    }
                    None => {
                        let _ = write!(md, " n/a |");
                    }
                }
            }
            let _ = writeln!(md);
        }
    }
    let _ = writeln!(md);
}

/// Destroyed runs per seed (over every rule and attack) at each attacked count and alpha:
/// whether one seed's draw of attackers and training phases decides the cells.
fn per_seed_table(md: &mut String, h: &Hetero) {
    let _ = writeln!(
        md,
        "### Destroyed runs per seed\n\nEach seed draws which robots are Byzantine and every \
         robot's training phase (the same at every alpha, rule and attack); per seed, the \
         destroyed runs over every rule and attack. A seed that holds most of a column's runs \
         decides its cells (`{}-runs.csv` has every run).\n",
        h.experiment
    );
    let mut columns = vec!["seed".to_string()];
    for &c in &attacked(h) {
        columns.extend(h.alphas.iter().map(|a| format!("{c} Byz, alpha {a}")));
    }
    columns.push("all".to_string());
    markdown::header(md, &columns);
    for seed in h.seeds() {
        let _ = write!(md, "| {seed} |");
        let (mut all_k, mut all_n) = (0, 0);
        for &c in &attacked(h) {
            for a in &h.alphas {
                let runs = h
                    .cells
                    .iter()
                    .filter(|x| x.count == c && &x.alpha == a)
                    .flat_map(|x| x.runs.iter().filter(|r| r.seed == seed));
                let (k, n) = runs.fold((0, 0), |(k, n), r| (k + usize::from(r.destroyed()), n + 1));
                all_k += k;
                all_n += n;
                let _ = write!(md, " {k}/{n} |");
            }
        }
        let _ = writeln!(md, " {all_k}/{all_n} |");
    }
    let _ = writeln!(md);
}

/// A number for the CSV files: shortest round-trip text, empty for none.
fn num(v: Option<f64>) -> String {
    v.map_or_else(String::new, |v| format!("{v:e}"))
}

/// `<experiment>-cells.csv`: per rule, alpha and count, the worst attack, its mean fraction and
/// per-seed spread, and the destroyed runs over every attack with their Wilson interval.
pub(super) fn cells_csv(h: &Hetero) -> String {
    let mut csv = String::from(
        "rule,alpha,count,worst_attack,worst_mean,worst_min,worst_median,worst_max,\
         destroyed,runs,destroyed_low,destroyed_high\n",
    );
    for rule in &h.rules {
        for a in &h.alphas {
            for &c in &h.counts {
                let Some(w) = h.worst(rule, a, c) else {
                    continue;
                };
                let s = w.cell.sorted();
                let (k, n) = h.destroyed(rule, a, c);
                let (lo, hi) = wilson(k, n);
                let _ = writeln!(
                    csv,
                    "{rule},{a},{c},{},{},{},{},{},{k},{n},{},{}",
                    w.cell.attack,
                    num(Some(w.mean)),
                    num(s.first().copied()),
                    num(Some(median(&s))),
                    num(s.last().copied()),
                    num(Some(lo)),
                    num(Some(hi)),
                );
            }
        }
    }
    csv
}

/// `<experiment>-runs.csv`: one line per run, grid order then seed.
pub(super) fn runs_csv(h: &Hetero) -> String {
    let mut csv =
        String::from("alpha,rule,attack,count,seed,genesis_loss,final_loss,fraction,destroyed\n");
    for c in &h.cells {
        for r in &c.runs {
            let _ = writeln!(
                csv,
                "{},{},{},{},{},{},{},{},{}",
                c.alpha,
                c.rule,
                c.attack,
                c.count,
                r.seed,
                num(Some(r.genesis)),
                num(Some(r.last)),
                num(Some(r.fraction())),
                r.destroyed()
            );
        }
    }
    csv
}

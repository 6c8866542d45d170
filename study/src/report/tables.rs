//! The report's text: `numbers.csv` and `series.csv` (every deterministic number),
//! `timing.csv` (wall-clock times, kept apart) and `report.md`.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::plots::Figure;
use super::stats::{ExperimentStats, PointStats, Stat, BIN_S};
use super::study::Section;

/// A CSV field: quoted (with doubled quotes) when it holds a comma, a quote or a line break.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// A point's overrides as one text: `key=value` separated by spaces, as `--set` takes them.
pub fn overrides_text(p: &PointStats) -> String {
    p.overrides.join(" ")
}

/// Writes `numbers.csv` (scalar metrics, each row with its point's simulated duration and
/// every override it was run with) and `series.csv` (curves) as text: every deterministic
/// number of the report, with full precision.
pub fn numbers_csv(stats: &[ExperimentStats]) -> (String, String) {
    let ci = |s: &Stat| s.ci.map_or_else(String::new, |c| format!("{c:e}"));
    let mut numbers = String::from("experiment,point,x,n,metric,mean,ci95,duration_s,overrides\n");
    let mut series = String::from("experiment,point,metric,time_s,n,mean,ci95\n");
    for e in stats {
        for p in &e.points {
            let duration = p.duration_s.map_or_else(String::new, |d| d.to_string());
            let overrides = csv_field(&overrides_text(p));
            for (k, s) in &p.metrics {
                let _ = writeln!(
                    numbers,
                    "{},{},{},{},{},{:e},{},{duration},{overrides}",
                    e.name,
                    csv_field(&p.point),
                    p.x,
                    s.n,
                    k,
                    s.mean,
                    ci(s)
                );
            }
            for (metric, c) in [
                ("loss", &p.loss),
                ("heldout_loss", &p.heldout),
                ("chain_mb", &p.chain_mb),
            ] {
                for (t, s) in c {
                    let _ = writeln!(
                        series,
                        "{},{},{},{},{},{:e},{}",
                        e.name,
                        p.point,
                        metric,
                        t,
                        s.n,
                        s.mean,
                        ci(s)
                    );
                }
            }
        }
    }
    (numbers, series)
}

/// `timing.csv`: each point's wall-clock seconds per run (not deterministic, so not in
/// `numbers.csv`).
pub fn timing_csv(stats: &[ExperimentStats]) -> String {
    let mut timing = String::from("experiment,point,n,wall_s_mean,wall_s_ci95\n");
    for e in stats {
        for p in &e.points {
            if let Some(w) = p.wall_s {
                let _ = writeln!(
                    timing,
                    "{},{},{},{},{}",
                    e.name,
                    p.point,
                    w.n,
                    w.mean,
                    w.ci.map_or_else(String::new, |c| c.to_string())
                );
            }
        }
    }
    timing
}

/// The columns that place an experiment's points in its table, and per point its cells: a
/// `--grid` sweep's keys, each point's value on each (text as given,
/// [`super::coords::UNSET`] where a point does not set the key); a built-in experiment's axis
/// and each point's x.
pub fn point_columns(e: &ExperimentStats) -> (Vec<String>, Vec<Vec<String>>) {
    match &e.grid {
        Some(g) => (
            g.keys.clone(),
            (0..e.points.len())
                .map(|i| {
                    (0..g.keys.len())
                        .map(|j| g.value(i, j).replace('|', "\\|"))
                        .collect()
                })
                .collect(),
        ),
        None => (
            vec![e.axis.clone()],
            e.points.iter().map(|p| vec![p.x.to_string()]).collect(),
        ),
    }
}

/// `report.md`: per experiment its figures, its study reports' `sections` and the table of
/// every point's numbers, then the notes.
pub fn markdown(
    stats: &[ExperimentStats],
    figures: &[Figure],
    sections: &[Section],
    notes: &[String],
    files: usize,
) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# swarmfl report\n");
    let _ = writeln!(
        md,
        "{files} result files. Means over runs with 95 % Student-t confidence intervals \
         (`mean ± half-width`; none for a single run). Loss curves use {BIN_S} s bins. \
         All numbers at full precision: `numbers.csv`, `series.csv`; wall-clock times: \
         `timing.csv`.\n"
    );
    for e in stats {
        experiment_section(&mut md, e, figures, sections);
    }
    if !notes.is_empty() {
        let _ = writeln!(md, "## Notes\n");
        for n in notes {
            let _ = writeln!(md, "- {n}");
        }
    }
    md
}

/// An experiment's section of `report.md`: its figures, its own tables, then
/// [`points_tables`].
fn experiment_section(
    md: &mut String,
    e: &ExperimentStats,
    figures: &[Figure],
    sections: &[Section],
) {
    let _ = writeln!(md, "## {}\n", e.name);
    for f in figures.iter().filter(|f| f.experiment == e.name) {
        let _ = writeln!(
            md,
            "![{}]({}.png)\n\n*{}* ([SVG]({}.svg))\n",
            f.caption, f.stem, f.caption, f.stem
        );
    }
    for s in sections.iter().filter(|s| s.experiment == e.name) {
        let _ = writeln!(md, "{}", s.text);
    }
    points_tables(md, e);
    let _ = writeln!(md);
}

/// The round majorities, when the summaries measured them (they were added with the authors'
/// timing, issue #58): per point, the fraction of a run's rounds whose accepted submissions
/// were more than half Byzantine, averaged over its runs.
fn majority_table(md: &mut String, e: &ExperimentStats) {
    let rated: Vec<(&PointStats, usize, String)> = e
        .points
        .iter()
        .filter_map(|p| {
            let s = p.metrics.get("byzantine_majority_rate")?;
            Some((p, s.n, s.text(3)))
        })
        .collect();
    if rated.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "\nRounds with a Byzantine majority (more than half of the round's accepted \
         submissions Byzantine), as a fraction of the run's rounds; runs: those whose \
         summaries count them (summaries made before the count lack it):\n\n| point | runs | \
         Byzantine majority rate |\n|---|---|---|"
    );
    for (p, runs, rate) in rated {
        let _ = writeln!(md, "| {} | {} | {} |", p.point, runs, rate);
    }
}

/// The table of every point's numbers, the table of every point's settings and a note per
/// section some result files lack.
fn points_tables(md: &mut String, e: &ExperimentStats) {
    let get = |p: &PointStats, k: &str, digits: usize| {
        p.metrics
            .get(k)
            .map_or_else(|| "n/a".to_string(), |s| s.text(digits))
    };
    let (keys, coordinates) = point_columns(e);
    let _ = writeln!(
        md,
        "| point | {} | runs | rounds | final loss | final held-out loss | honest gain (tokens) | Byzantine gain (tokens) | chain MB | wall s/run |",
        keys.join(" | ")
    );
    let _ = writeln!(
        md,
        "|---|{}---|---|---|---|---|---|---|---|",
        "---|".repeat(keys.len())
    );
    for (p, coordinates) in e.points.iter().zip(&coordinates) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            p.point,
            coordinates.join(" | "),
            p.seeds.len(),
            get(p, "rounds", 1),
            get(p, "final_loss", 5),
            get(p, "final_heldout_loss", 5),
            get(p, "honest_gain", 2),
            get(p, "byzantine_gain", 2),
            get(p, "chain_mb", 2),
            p.wall_s.map_or_else(|| "n/a".to_string(), |s| s.text(1)),
        );
    }
    majority_table(md, e);
    let _ = writeln!(
        md,
        "\nSettings: preset `{}`; per point the simulated duration and every override \
         (the point's, then the sweep's `--set`).\n\n| point | duration s | overrides |\n|---|---|---|",
        e.preset
    );
    for p in &e.points {
        let overrides = overrides_text(p);
        let _ = writeln!(
            md,
            "| {} | {} | {} |",
            p.point,
            p.duration_s
                .map_or_else(|| "n/a".to_string(), |d| d.to_string()),
            if overrides.is_empty() {
                "(none)".to_string()
            } else {
                format!("`{}`", overrides.replace('|', "\\|"))
            }
        );
    }
    let mut missing: BTreeMap<&str, usize> = BTreeMap::new();
    for p in &e.points {
        for (k, n) in &p.missing {
            *missing.entry(k).or_default() += n;
        }
    }
    for (section, n) in missing {
        let _ = writeln!(
            md,
            "\nNote: {n} result files have no `{section}` section; the figures and columns that need it are skipped (n/a)."
        );
    }
}

#[cfg(test)]
mod tests {
    use super::super::coords::tests::two_key_grid;
    use super::*;

    #[test]
    fn a_grid_is_tabled_with_a_column_per_key_showing_its_values() {
        let points = two_key_grid();
        let e = ExperimentStats {
            name: "grid-smoke".into(),
            axis: "contract.rule".into(),
            preset: "smoke".into(),
            grid: super::super::stats::grid_coords(&points),
            points,
        };
        let (keys, cells) = point_columns(&e);
        assert_eq!(keys, ["contract.rule", "byzantine.count"]);
        assert_eq!(
            cells,
            [
                ["median", "1"],
                ["median", "3"],
                ["krum", "1"],
                ["krum", "3"]
            ]
        );
        let md = markdown(&[e], &[], &[], &[], 8);
        assert!(
            md.contains("| point | contract.rule | byzantine.count | runs | rounds |"),
            "{md}"
        );
        assert!(md.contains("|---|---|---|---|---|"), "{md}");
        // `--grid contract.rule='"krum"'`: the directory name has `_` for the quotes, the
        // column the value.
        assert!(
            md.contains("| contract.rule=_krum_+byzantine.count=3 | krum | 3 | 2 |"),
            "{md}"
        );
    }
}

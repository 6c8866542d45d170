//! `swarmfl ranking`: where the Byzantine and the honest submissions sat in their rounds'
//! rankings, over many runs (issue #36, claim 12). Each log is folded once
//! (`inspect::index_run`); the contract's own record of every closed round of the final
//! canonical chain gives each submission's distance to the shared model, the round's median
//! distance, the rank it was given and what it was paid (`inspect::RankedSubmission`). The runs
//! are grouped by point, the ranking they ran under (`contract.rank_order`) x
//! `byzantine.kind` x `byzantine.count` x the value of every other configuration key on which
//! the runs differ (`contract.rule` in a grid over rules; a column each in the files after
//! `count`), and summarised with the report's 95 % intervals.
//!
//! Files written into the output directory: `rounds.csv` (per run and closed round: the
//! median distance, whether a Byzantine model held it, and each group's mean position),
//! `runs.csv` (per run), `points.csv` and `points.json` (per point: n, mean and 95 %
//! half-width of every run metric), with `--submissions` also `submissions.csv` (every counted
//! submission, large), and the figures `<kind>-gain`, `-tokens`, `-rank`, `-position` and
//! `-median` (SVG and PNG, the report's style). `measure` defines every number; `figures`
//! draws them. Logs are read in path order and runs sorted by point and seed before any sum, so
//! the files do not depend on discovery order.

mod figures;
mod measure;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use swarmfl_core::config::RankKey;
use swarmfl_core::inspect::{self, RankedSubmission, Table};

use crate::progress::{warn_if_truncated, Watch};
use crate::results::find_logs;
use measure::{Group, Point, PointStats, RoundMeasure, RunMeasure};

/// One measured run.
struct Run {
    point: Point,
    /// Its configuration, every key (`Config::flat_values`).
    config: BTreeMap<String, String>,
    seed: u64,
    /// The log's path relative to the input it was found under.
    log: String,
    rounds: Vec<RoundMeasure>,
    measure: RunMeasure,
    /// Its submissions' table (kept only for `--submissions`).
    submissions: Option<Table>,
}

/// Measures every log found under `inputs` and writes the files into `out`; returns the table
/// printed on stdout (per point: runs, Byzantine and honest token gains and their difference).
/// A truncated log is warned of on `watch`.
pub fn ranking(
    inputs: &[PathBuf],
    out: &Path,
    submissions: bool,
    watch: &dyn Watch,
) -> anyhow::Result<String> {
    let logs = find_logs(inputs)?;
    let mut runs = Vec::with_capacity(logs.len());
    for (path, name) in &logs {
        runs.push(measure_log(path, name, submissions, watch)?);
    }
    tell_apart(&mut runs)?;
    let keys: Vec<String> = runs
        .first()
        .map(|r| r.point.setting.iter().map(|(k, _)| k.clone()).collect())
        .unwrap_or_default();
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    write_rounds(&out.join("rounds.csv"), &keys, &runs)?;
    write_runs(&out.join("runs.csv"), &keys, &runs)?;
    let mut by_point: BTreeMap<Point, Vec<RunMeasure>> = BTreeMap::new();
    for r in &runs {
        by_point
            .entry(r.point.clone())
            .or_default()
            .push(r.measure.clone());
    }
    let points = measure::points(&by_point);
    write_points_csv(&out.join("points.csv"), &keys, &points)?;
    write_points_json(&out.join("points.json"), &by_point, &points)?;
    if submissions {
        write_submissions(&out.join("submissions.csv"), &keys, &runs)?;
    }
    let with_text = figures::draw_all(&points, out)?;
    let mut text = format!(
        "wrote {}: {} runs, {} points{}\n",
        out.display(),
        runs.len(),
        points.len(),
        if with_text {
            ""
        } else {
            " (figures without text: no font could be loaded)"
        }
    );
    text.push_str(&summary_table(&points));
    Ok(text)
}

/// Gives each run's point the other configuration keys on which the runs differ
/// ([`measure::settings`]), sorts the runs by point and seed, and refuses two runs of one
/// point and seed (one configuration, given twice), naming both logs.
fn tell_apart(runs: &mut [Run]) -> anyhow::Result<()> {
    let configs: Vec<BTreeMap<String, String>> = runs.iter().map(|r| r.config.clone()).collect();
    for (r, setting) in runs.iter_mut().zip(measure::settings(&configs)) {
        r.point.setting = setting;
    }
    runs.sort_by(|a, b| (&a.point, a.seed).cmp(&(&b.point, b.seed)));
    for pair in runs.windows(2) {
        let p = &pair[0].point;
        anyhow::ensure!(
            (p, pair[0].seed) != (&pair[1].point, pair[1].seed),
            "{} and {} are the same run (ranking {}, {} x {}{}, seed {}; their configurations \
             are equal): give each run once",
            pair[0].log,
            pair[1].log,
            p.ranking,
            p.count,
            p.kind,
            if p.setting.is_empty() {
                String::new()
            } else {
                format!(", {}", p.setting_text())
            },
            pair[0].seed
        );
    }
    Ok(())
}

/// Folds one log and measures it.
fn measure_log(
    path: &Path,
    name: &str,
    submissions: bool,
    watch: &dyn Watch,
) -> anyhow::Result<Run> {
    let index = inspect::index_run(path, None)?;
    warn_if_truncated(watch, &index);
    let rows: Vec<RankedSubmission> = index.ranked_submissions()?;
    let config = &index.config;
    let params = index.final_state.ledger.params();
    let scale = config.contract.weight_scale;
    let token_units = config.contract.token_units;
    let rounds = measure::rounds(&rows, token_units, |u| params.distance_per_weight(u, scale));
    let initial = config.contract.initial_tokens * token_units;
    let gains: Vec<f64> = index
        .contract_at(index.last_height())
        .balances
        .iter()
        .map(|&b| (b as f64 - initial as f64) / token_units as f64)
        .collect();
    let measure = measure::run(&rows, &rounds, token_units, &gains, &index.byzantine);
    let ranking = match config.contract.rank_key {
        RankKey::Distance => config.contract.rank_order.name().to_string(),
        RankKey::Mae => format!("{}+mae", config.contract.rank_order.name()),
    };
    Ok(Run {
        point: Point {
            ranking,
            kind: config.byzantine.kind.name().to_string(),
            count: config.byzantine.count,
            setting: Vec::new(),
        },
        config: config.flat_values(),
        seed: index.seed,
        log: name.to_string(),
        rounds,
        measure,
        submissions: if submissions {
            Some(index.ranking_table()?)
        } else {
            None
        },
    })
}

/// A float as CSV text: Rust's shortest round-trip form (`NaN` where undefined).
fn num(v: f64) -> String {
    v.to_string()
}

/// The leading columns naming a point: ranking, kind, count, then the value of each other
/// key that tells the runs apart.
fn point_columns(p: &Point) -> Vec<String> {
    let mut row = vec![p.ranking.clone(), p.kind.clone(), p.count.to_string()];
    row.extend(p.setting.iter().map(|(_, v)| v.clone()));
    row
}

/// The header of [`point_columns`], the other keys being `keys`.
fn point_header(keys: &[String]) -> Vec<String> {
    let mut header: Vec<String> = ["ranking", "kind", "count"].map(String::from).to_vec();
    header.extend(keys.iter().cloned());
    header
}

/// The leading columns naming a run: its point's, then the seed.
fn run_columns(r: &Run) -> Vec<String> {
    let mut row = point_columns(&r.point);
    row.push(r.seed.to_string());
    row
}

/// The header of [`run_columns`].
fn run_header(keys: &[String]) -> Vec<String> {
    let mut header = point_header(keys);
    header.push("seed".into());
    header
}

fn writer(path: &Path) -> anyhow::Result<csv::Writer<std::fs::File>> {
    csv::Writer::from_path(path).with_context(|| format!("cannot write {}", path.display()))
}

fn write_rounds(path: &Path, keys: &[String], runs: &[Run]) -> anyhow::Result<()> {
    let mut w = writer(path)?;
    let mut header = run_header(keys);
    header.extend(
        [
            "round",
            "accepted",
            "byzantine_accepted",
            "median_distance",
            "median_byzantine",
            "byzantine_below_honest",
        ]
        .map(String::from),
    );
    for g in Group::BOTH {
        for m in [
            "submissions",
            "distance_ratio",
            "off_median_ratio",
            "rank",
            "penalised",
            "submission_gain",
        ] {
            header.push(format!("{}_{m}", g.name()));
        }
    }
    w.write_record(&header)?;
    for r in runs {
        for m in &r.rounds {
            let mut row = run_columns(r);
            row.extend([
                m.round.to_string(),
                m.accepted.to_string(),
                m.byzantine_accepted.to_string(),
                num(m.median_distance),
                m.median_byzantine.to_string(),
                m.byzantine_below_honest.to_string(),
            ]);
            for p in &m.groups {
                row.extend([
                    p.submissions.to_string(),
                    num(p.distance_ratio),
                    num(p.off_median_ratio),
                    num(p.rank),
                    num(p.penalised),
                    num(p.gain_tokens),
                ]);
            }
            w.write_record(&row)?;
        }
    }
    w.flush()
        .with_context(|| format!("cannot write {}", path.display()))
}

fn write_runs(path: &Path, keys: &[String], runs: &[Run]) -> anyhow::Result<()> {
    let mut w = writer(path)?;
    let mut header = run_header(keys);
    header.push("log".into());
    if let Some(first) = runs.first() {
        header.extend(measure::metrics(&first.measure).into_iter().map(|(n, _)| n));
    }
    w.write_record(&header)?;
    for r in runs {
        let mut row = run_columns(r);
        row.push(r.log.clone());
        row.extend(
            measure::metrics(&r.measure)
                .into_iter()
                .map(|(_, v)| num(v)),
        );
        w.write_record(&row)?;
    }
    w.flush()
        .with_context(|| format!("cannot write {}", path.display()))
}

fn write_points_csv(path: &Path, keys: &[String], points: &[PointStats]) -> anyhow::Result<()> {
    let mut w = writer(path)?;
    let mut header = point_header(keys);
    if let Some((_, stats)) = points.first() {
        for (name, _) in stats {
            header.extend([
                format!("{name}_n"),
                format!("{name}_mean"),
                format!("{name}_ci95"),
            ]);
        }
    }
    w.write_record(&header)?;
    for (p, stats) in points {
        let mut row = point_columns(p);
        for (_, s) in stats {
            match s {
                Some(s) => row.extend([
                    s.n.to_string(),
                    num(s.mean),
                    s.ci.map_or(String::new(), num),
                ]),
                None => row.extend(["0".to_string(), String::new(), String::new()]),
            }
        }
        w.write_record(&row)?;
    }
    w.flush()
        .with_context(|| format!("cannot write {}", path.display()))
}

fn write_points_json(
    path: &Path,
    runs: &BTreeMap<Point, Vec<RunMeasure>>,
    points: &[PointStats],
) -> anyhow::Result<()> {
    let value: Vec<serde_json::Value> = points
        .iter()
        .map(|(p, stats)| {
            let metrics: serde_json::Map<String, serde_json::Value> = stats
                .iter()
                .map(|(name, s)| {
                    let v = match s {
                        Some(s) => serde_json::json!({"n": s.n, "mean": finite(s.mean), "ci95": s.ci.and_then(finite)}),
                        None => serde_json::json!({"n": 0, "mean": null, "ci95": null}),
                    };
                    (name.clone(), v)
                })
                .collect();
            let mut point = serde_json::json!({
                "ranking": p.ranking,
                "kind": p.kind,
                "count": p.count,
                "runs": runs.get(p).map_or(0, Vec::len),
                "metrics": metrics,
            });
            if !p.setting.is_empty() {
                point["setting"] = p
                    .setting
                    .iter()
                    .map(|(k, v)| (k.clone(), serde_json::Value::from(v.as_str())))
                    .collect::<serde_json::Map<_, _>>()
                    .into();
            }
            point
        })
        .collect();
    let text = serde_json::to_string_pretty(&value)? + "\n";
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// A finite float, or `None` (JSON has no NaN).
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

fn write_submissions(path: &Path, keys: &[String], runs: &[Run]) -> anyhow::Result<()> {
    let mut w = writer(path)?;
    let mut wrote_header = false;
    for r in runs {
        let Some(table) = &r.submissions else {
            continue;
        };
        if !wrote_header {
            let mut header = run_header(keys);
            header.extend(table.names().into_iter().map(String::from));
            w.write_record(&header)?;
            wrote_header = true;
        }
        for i in 0..table.rows() {
            let mut row = run_columns(r);
            row.extend(table.columns.iter().map(|(_, c)| c.cell(i)));
            w.write_record(&row)?;
        }
    }
    w.flush()
        .with_context(|| format!("cannot write {}", path.display()))
}

/// The stdout table: per point, runs and the token gains with their 95 % half-widths.
fn summary_table(points: &[PointStats]) -> String {
    let mut text = String::from(
        "ranking  kind  count  runs  byzantine gain  honest gain  byzantine - honest\n",
    );
    for (p, stats) in points {
        let get = |name: &str| {
            stats
                .iter()
                .find(|(n, _)| n == name)
                .and_then(|(_, s)| *s)
                .map_or("-".to_string(), |s| s.text(2))
        };
        let runs = stats
            .iter()
            .find(|(n, _)| n == "rounds")
            .and_then(|(_, s)| *s)
            .map_or(0, |s| s.n);
        let _ = writeln!(
            text,
            "{}  {}  {}{}  {}  {}  {}  {}",
            p.ranking,
            p.kind,
            p.count,
            if p.setting.is_empty() {
                String::new()
            } else {
                format!(" ({})", p.setting_text())
            },
            runs,
            get("byzantine_gain"),
            get("honest_gain"),
            get("gain_difference")
        );
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of `rule` at `count` faulty robots and seed `seed`, its configuration the
    /// smoke preset's with those set (flattened as `Config::flat_values`).
    fn run_of(rule: &str, count: u32, seed: u64) -> Run {
        let overrides = [
            format!("contract.rule={rule}"),
            "byzantine.kind=faulty".to_string(),
            format!("byzantine.count={count}"),
        ];
        let config =
            swarmfl_core::config::Config::resolve(Some("smoke"), None, &overrides).unwrap();
        let position = measure::Position {
            submissions: 0,
            distance_ratio: f64::NAN,
            off_median_ratio: f64::NAN,
            rank: f64::NAN,
            penalised: f64::NAN,
            gain_tokens: f64::NAN,
        };
        Run {
            point: Point {
                ranking: config.contract.rank_order.name().to_string(),
                kind: config.byzantine.kind.name().to_string(),
                count,
                setting: Vec::new(),
            },
            config: config.flat_values(),
            seed,
            log: format!("{rule}-{count}/seed{seed}/run.swlog"),
            rounds: Vec::new(),
            measure: RunMeasure {
                rounds: 0,
                median_byzantine: 0.0,
                byzantine_below_honest: f64::NAN,
                groups: [position; 2],
                token_gain: [0.0, 0.0],
            },
            submissions: None,
        }
    }

    /// `sweep --grid contract.rule=median,krum --grid byzantine.count=1,3`: the rule is not
    /// one of a point's own fields, yet the runs differ in it, so they are different runs,
    /// and the rule is a column of their point. The same configuration and seed twice is
    /// still refused.
    #[test]
    fn runs_that_differ_in_any_key_are_different_runs() {
        let mut runs: Vec<Run> = ["median", "krum"]
            .iter()
            .flat_map(|rule| [1, 3].map(|count| run_of(rule, count, 1)))
            .collect();
        tell_apart(&mut runs).unwrap();
        let points: Vec<String> = runs
            .iter()
            .map(|r| point_columns(&r.point).join(","))
            .collect();
        assert_eq!(
            points,
            [
                "median,faulty,1,krum",
                "median,faulty,1,median",
                "median,faulty,3,krum",
                "median,faulty,3,median"
            ]
        );
        assert_eq!(
            run_header(&["contract.rule".to_string()]),
            ["ranking", "kind", "count", "contract.rule", "seed"]
        );
        // Runs that differ only in the point's own fields have no other column.
        let mut runs = vec![run_of("median", 1, 1), run_of("median", 3, 1)];
        tell_apart(&mut runs).unwrap();
        assert!(runs.iter().all(|r| r.point.setting.is_empty()));
        // One configuration and seed twice: one run given twice.
        let mut runs = vec![
            run_of("krum", 1, 1),
            run_of("median", 1, 1),
            run_of("krum", 1, 1),
        ];
        let err = tell_apart(&mut runs).unwrap_err().to_string();
        assert!(
            err.contains("krum-1/seed1/run.swlog and krum-1/seed1/run.swlog are the same run")
                && err.contains("contract.rule=krum, seed 1"),
            "{err}"
        );
    }
}

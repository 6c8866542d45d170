//! `swarmfl traffic`: bytes sent and stored per node over time, from logs (issue 32: what one
//! node carries as the swarm grows). Each log is folded once (`inspect::traffic`, which
//! defines every number: the summary's `bytes_sent_per_robot_mean` and
//! `bytes_stored_per_robot_mean` at every period's end, with the spread over nodes); the last
//! row of a run is its summary's end values, bit for bit.
//!
//! Printed (one table per run, MB per node) or, with `--csv`, one CSV of every run's rows in
//! bytes on stdout; with `--out DIR`, that CSV as `DIR/traffic.csv`, the figures
//! `traffic-sent-<N>` and `traffic-stored-<N>` per swarm size N (a line per aggregation, the
//! mean over nodes, then over seeds) and `traffic-sent-rate` and `traffic-stored-rate` (the
//! growth per node over the second half of the run versus the swarm's size), SVG and PNG in the
//! report's style. Runs are sorted by aggregation, size and seed before anything is written, so
//! the files do not depend on the order the logs were found in.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use swarmfl_core::inspect::{self, Table, Traffic};
use swarmfl_core::SimTime;

use crate::progress::Watch;
use crate::report::plots::{self, Kind, Plot, Series};
use crate::report::stats::{fixed, Stat};
use crate::report::written_list;
use crate::results::find_logs;

/// One measured log: its name (relative to the input it was found under) and rows.
pub struct Run {
    log: String,
    traffic: Traffic,
}

impl Run {
    /// The sort key: aggregation (chain's rounds, buffered, then the baselines), size, seed.
    fn key(&self) -> (u8, u32, u64) {
        let order = match self.traffic.mode() {
            "rounds" => 0,
            "buffered" => 1,
            "gossip" => 2,
            _ => 3,
        };
        (order, self.traffic.config.world.robots, self.traffic.seed)
    }
}

/// Folds every log named by `inputs` (logs, or directories searched for `run.swlog`), sorted
/// by aggregation, size and seed; two logs of one run are refused. Says on `watch` which log
/// it folds when there are several.
pub fn measure(inputs: &[PathBuf], every: SimTime, watch: &dyn Watch) -> anyhow::Result<Vec<Run>> {
    let logs = find_logs(inputs)?;
    let mut runs = Vec::with_capacity(logs.len());
    for (path, name) in &logs {
        if logs.len() > 1 {
            watch.say(&format!("folding {}", path.display()));
        }
        runs.push(Run {
            log: name.clone(),
            traffic: inspect::traffic(path, every)?,
        });
    }
    runs.sort_by_key(Run::key);
    for pair in runs.windows(2) {
        anyhow::ensure!(
            pair[0].key() != pair[1].key() || pair[0].traffic.config != pair[1].traffic.config,
            "{} and {} are the same run ({}, {} robots, seed {}): give each run once",
            pair[0].log,
            pair[1].log,
            pair[0].traffic.mode(),
            pair[0].traffic.config.world.robots,
            pair[0].traffic.seed
        );
    }
    Ok(runs)
}

/// Megabytes (10^6 bytes), as the report counts them.
fn mb(bytes: f64) -> f64 {
    bytes / 1e6
}

/// `v` with 3 decimals, never `-0.000` (a flat series' growth, rounded).
fn mb3(v: f64) -> String {
    fixed(v, 3)
}

/// One table per run, MB per node: mean and [min, median, max] over nodes.
pub fn tables(runs: &[Run]) -> String {
    let mut text = String::new();
    for run in runs {
        let t = &run.traffic;
        let _ = writeln!(
            text,
            "{}: {}, {} robots, seed {}; MB per node, mean [min, median, max] over nodes",
            run.log,
            t.mode(),
            t.config.world.robots,
            t.seed
        );
        let _ = writeln!(
            text,
            "{:>9}  {:>36}  {:>36}",
            "time (s)", "sent so far", "stored now"
        );
        for r in &t.rows {
            let spread = |s: &inspect::Spread| {
                format!(
                    "{:.3} [{:.3}, {:.3}, {:.3}]",
                    mb(s.mean),
                    mb(s.min as f64),
                    mb(s.median as f64),
                    mb(s.max as f64)
                )
            };
            let _ = writeln!(
                text,
                "{:>9}  {:>36}  {:>36}",
                format!("{:.1}", r.time.secs()),
                spread(&r.sent),
                spread(&r.stored)
            );
        }
    }
    text
}

/// Every run's rows as one CSV, bytes per node: the run's log, aggregation, size and seed,
/// then the columns of `Traffic::table`.
pub fn csv_text(runs: &[Run]) -> anyhow::Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["log", "mode", "robots", "seed"];
    let first: Table = runs.first().map(|r| r.traffic.table()).unwrap_or_default();
    header.extend(first.names());
    w.write_record(&header)?;
    for run in runs {
        let t = &run.traffic;
        let table = t.table();
        let fixed = [
            run.log.clone(),
            t.mode().to_string(),
            t.config.world.robots.to_string(),
            t.seed.to_string(),
        ];
        for i in 0..table.rows() {
            let row = fixed
                .iter()
                .cloned()
                .chain(table.columns.iter().map(|(_, c)| c.cell(i)));
            w.write_record(row)?;
        }
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

/// The growth per node over the second half of a run, bytes per simulated 1000 s: from the
/// first row at or after half the run to the last.
fn rate(t: &Traffic, read: Read) -> Option<f64> {
    let last = t.rows.last()?;
    let half = SimTime(last.time.0 / 2);
    let from = t.rows.iter().find(|r| r.time >= half)?;
    let span_s = last.time.secs() - from.time.secs();
    (span_s > 0.0).then(|| (read(last) - read(from)) / span_s * 1000.0)
}

/// A quantity's value in a row, bytes per node.
type Read = fn(&inspect::TrafficRow) -> f64;

/// The two quantities: file stem, what it is, and its value in a row.
const QUANTITIES: [(&str, &str, Read); 2] = [
    ("sent", "bytes sent so far", |r| r.sent.mean),
    ("stored", "bytes stored", |r| r.stored.mean),
];

/// Writes `traffic.csv` and the figures into `out`; returns what it printed (every file
/// written, one a line, then per run the end values and the growth over the second half).
pub fn write_study(runs: &[Run], out: &Path) -> anyhow::Result<String> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let csv_path = out.join("traffic.csv");
    std::fs::write(&csv_path, csv_text(runs)?)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let mut with_text = true;
    let mut files = vec![csv_path];
    for (stem, plot) in over_time(runs).into_iter().chain(rates(runs)) {
        with_text &= plots::draw(&plot, out, &stem)?;
        files.extend(["svg", "png"].map(|ext| out.join(format!("{stem}.{ext}"))));
    }
    let mut text = written_list(out, &files);
    let _ = writeln!(
        text,
        "{} runs{}",
        runs.len(),
        if with_text {
            ""
        } else {
            "; the figures are without text: no font could be loaded"
        }
    );
    let _ = writeln!(
        text,
        "{:<10} {:>6} {:>4}  {:>14} {:>16}  {:>14} {:>16}",
        "mode",
        "robots",
        "seed",
        "sent MB/node",
        "MB/node/1000 s",
        "stored MB/node",
        "MB/node/1000 s"
    );
    for run in runs {
        let t = &run.traffic;
        let last = t.rows.last().expect("a run has its end row");
        let r = |read| rate(t, read).map_or("-".to_string(), |v| mb3(mb(v)));
        let _ = writeln!(
            text,
            "{:<10} {:>6} {:>4}  {:>14.3} {:>16}  {:>14.3} {:>16}",
            t.mode(),
            t.config.world.robots,
            t.seed,
            mb(last.sent.mean),
            r(QUANTITIES[0].2),
            mb(last.stored.mean),
            r(QUANTITIES[1].2),
        );
    }
    Ok(text)
}

/// The runs by swarm size, then aggregation (in sort order), each with its runs (seeds).
fn by_size(runs: &[Run]) -> BTreeMap<u32, Vec<(&'static str, Vec<&Traffic>)>> {
    let mut sizes: BTreeMap<u32, Vec<(&'static str, Vec<&Traffic>)>> = BTreeMap::new();
    for run in runs {
        let t = &run.traffic;
        let modes = sizes.entry(t.config.world.robots).or_default();
        match modes.last_mut() {
            Some((mode, seeds)) if *mode == t.mode() => seeds.push(t),
            _ => modes.push((t.mode(), vec![t])),
        }
    }
    sizes
}

/// Per swarm size and quantity, the per-node mean over time, a line per aggregation (the
/// mean over its seeds at each row time they all have, with a 95 % band from 2 seeds).
fn over_time(runs: &[Run]) -> Vec<(String, Plot<'static>)> {
    let mut out = Vec::new();
    for (robots, modes) in by_size(runs) {
        for (stem, what, read) in QUANTITIES {
            let series = modes
                .iter()
                .map(|(mode, seeds)| {
                    let rows = seeds.iter().map(|t| t.rows.len()).min().unwrap_or(0);
                    let points = (0..rows)
                        .filter_map(|i| {
                            let time = seeds[0].rows[i].time;
                            let values: Option<Vec<f64>> = seeds
                                .iter()
                                .map(|t| (t.rows[i].time == time).then(|| mb(read(&t.rows[i]))))
                                .collect();
                            Some((time.secs(), Stat::of(&values?)?))
                        })
                        .collect();
                    Series {
                        label: mode.to_string(),
                        points,
                    }
                })
                .collect();
            out.push((
                format!("traffic-{stem}-{robots}"),
                Plot {
                    title: format!("{what} per node, {robots} robots"),
                    x_label: "time (s)",
                    y_label: if stem == "sent" {
                        "sent per node so far (MB)"
                    } else {
                        "stored per node (MB)"
                    },
                    kind: Kind::Time { log_y: false },
                    series,
                    nonnegative: true,
                    x_ticks: Vec::new(),
                },
            ));
        }
    }
    out
}

/// Per quantity, the growth per node over the second half of the run versus the swarm's
/// size, a series per aggregation (mean over seeds, 95 % CI from 2 seeds; log x axis, linear
/// y: a flat series, gossip's replica, grows by 0).
fn rates(runs: &[Run]) -> Vec<(String, Plot<'static>)> {
    let sizes = by_size(runs);
    let mut modes: Vec<&'static str> = Vec::new();
    for run in runs {
        if !modes.contains(&run.traffic.mode()) {
            modes.push(run.traffic.mode());
        }
    }
    QUANTITIES
        .iter()
        .map(|&(stem, what, read)| {
            let series = modes
                .iter()
                .map(|mode| Series {
                    label: mode.to_string(),
                    points: sizes
                        .iter()
                        .filter_map(|(robots, by_mode)| {
                            let seeds = &by_mode.iter().find(|(m, _)| m == mode)?.1;
                            let values: Option<Vec<f64>> =
                                seeds.iter().map(|t| rate(t, read).map(mb)).collect();
                            Some((f64::from(*robots), Stat::of(&values?)?))
                        })
                        .collect(),
                })
                .collect();
            (
                format!("traffic-{stem}-rate"),
                Plot {
                    title: format!("growth of {what} per node, second half of the run"),
                    x_label: "robots",
                    y_label: "MB per node per 1000 s",
                    kind: Kind::Scaling { log_y: false },
                    series,
                    nonnegative: false,
                    x_ticks: Vec::new(),
                },
            )
        })
        .collect()
}

//! A sweep's report (`swarmfl report`): merges a sweep's result files and computes, per experiment and
//! configuration point, means and 95 % confidence intervals over runs, then draws the paper's
//! figures and writes `report.md` with a table of the numbers.
//!
//! The steps, one module each: `load` (read and sort the result files), `stats` (means and
//! intervals; the definitions are there), `plots` (drawing primitives), the study reports
//! listed in `study` (one trait; each experiment's entry in `experiments::ALL` names the one
//! that draws it): `figures` (the standard figures of each experiment), `robustness` (e4's
//! heatmaps), `benchmark` (the robustness benchmark's heatmaps on a heterogeneity axis),
//! `defence` (e5's figures), `scale` (e6's figures and tables), `heterogeneity`
//! (e4-heterogeneity's heatmaps) and `position` (e4-heterogeneity-measure's tables and figure); `coords` (a `--grid`
//! sweep's keys and values, which name its points in figures and tables), and `tables` (the
//! CSV files and `report.md`). `swarmfl report` prints every file it wrote.
//!
//! Results are sorted by experiment, point (in the grid's order) and seed before any sum, so
//! the numbers do not depend on file discovery order. `numbers.csv` and `series.csv` hold every
//! deterministic number (shards merged or one local sweep give identical files); wall-clock
//! times are kept apart in `timing.csv`.

mod benchmark;
mod coords;
mod defence;
mod figures;
mod frame;
mod heatmap;
mod heterogeneity;
mod load;
mod markdown;
pub(crate) mod plots;
mod position;
mod robustness;
mod scale;
pub(crate) mod stats;
mod study;
mod style;
mod tables;

use std::path::{Path, PathBuf};

use anyhow::Context;

pub use frame::{results_frame, Frame};
use study::StudyReport;

/// Every study report, in the order their figures are drawn, their files written and their
/// sections placed within an experiment's section of `report.md`.
pub(crate) const STUDIES: &[&dyn StudyReport] = &[
    &figures::StandardFigures,
    &robustness::Robustness,
    &benchmark::Benchmark,
    &heterogeneity::Heterogeneity,
    &defence::Defence,
    &scale::Scale,
    &position::PositionMeasure,
];

/// The list `report` and `traffic --out` print: `wrote N files into OUT:`, then each file's
/// path, one a line.
pub fn written_list(out: &Path, files: &[PathBuf]) -> String {
    let mut text = format!("wrote {} files into {}:\n", files.len(), out.display());
    for f in files {
        text.push_str(&format!("  {}\n", f.display()));
    }
    text
}

/// Makes the report of the results in `dir` into `out`: figures (SVG and PNG), `report.md`,
/// `numbers.csv`, `series.csv` and `timing.csv`. Returns the path of `report.md`.
pub fn report(dir: &Path, out: &Path) -> anyhow::Result<PathBuf> {
    make(dir, out)?;
    Ok(out.join("report.md"))
}

/// [`report`], returning every file written (the CSVs, each figure's SVG and PNG, and
/// `report.md` last).
pub fn make(dir: &Path, out: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let (results, mut notes) = load::load(dir)?;
    anyhow::ensure!(
        !results.is_empty(),
        "no result files found under {} (expected <experiment>/<point>/seed<N>.json)",
        dir.display()
    );
    let mut stats = stats::aggregate(&results);
    for study in STUDIES {
        study.extend(&results, &mut stats);
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut written = Vec::new();
    let mut write = |name: &str, text: String| -> anyhow::Result<()> {
        let path = out.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
        written.push(path);
        Ok(())
    };
    let (numbers, series) = tables::numbers_csv(&stats);
    write("numbers.csv", numbers)?;
    write("series.csv", series)?;
    write("timing.csv", tables::timing_csv(&stats))?;
    // Every study draws its figures before any writes its files.
    let (mut figures, mut sections, mut own_files) = (Vec::new(), Vec::new(), Vec::new());
    for study in STUDIES {
        let drawn = study.draw(&results, &stats, out, &mut notes)?;
        figures.extend(drawn.figures);
        own_files.extend(drawn.files);
        sections.extend(drawn.sections);
    }
    for (name, text) in own_files {
        write(&name, text)?;
    }
    let md = tables::markdown(&stats, &figures, &sections, &notes, results.len());
    write("report.md", md)?;
    let mut files: Vec<PathBuf> = figures
        .iter()
        .flat_map(|f| ["svg", "png"].map(|ext| out.join(format!("{}.{ext}", f.stem))))
        .collect();
    files.sort();
    let md = written.pop();
    written.extend(files);
    written.extend(md);
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::load::{load, sort, RunResult};
    use super::stats::aggregate;
    use super::tables::numbers_csv;
    use super::*;
    use crate::experiments::{self, EXPERIMENTS};
    use crate::results;
    use crate::summary::{ResultFile, SweepTask, Timing};
    use swarmfl_core::config::ByzantineKind;
    use swarmfl_core::metrics::ControlPoint;
    use swarmfl_core::rng::{self, Purpose};
    use swarmfl_core::summary::ChainBytesPoint;

    /// A synthetic summary that follows the schema of `summary.json` (`summary::RunSummary`) exactly, with values
    /// drawn from the seeded RNG. For tests only: not a result of any run.
    fn synthetic_summary(experiment: &str, x: f64, seed: u64) -> ResultFile {
        let mut r = rng::stream(seed * 1000 + x as u64, Purpose::Dropout, 0);
        let sim_time_s = 5000.0;
        // e1-expiration's x is the expiration time, e6's the swarm's size.
        let byzantine = if experiment == "e1-expiration" || experiment.starts_with("e6-scale") {
            0
        } else {
            x as u32
        };
        let rounds = 40 + r.below(20) as usize;
        let mut t = 0.0;
        let mut loss = 0.3;
        let (mut times, mut losses, mut heldout) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..rounds {
            t += 60.0 + r.uniform() * 60.0;
            loss *= 0.9 + 0.05 * r.uniform() + 0.01 * f64::from(byzantine);
            times.push(t);
            losses.push(loss);
            heldout.push(loss * 1.2);
        }
        let chain: Vec<ChainBytesPoint> = (1..=50)
            .map(|k| {
                let mean = f64::from(k) * 2.0e6 * (1.0 + 0.1 * r.uniform());
                ChainBytesPoint {
                    time_s: f64::from(k) * 100.0,
                    mean,
                    max: mean * 1.05,
                    stored_mean: 0.0,
                    sent_mean: 0.0,
                }
            })
            .collect();
        // A reduced-study run's file for every figure the report does not read.
        let mut made = crate::summary::tests::example();
        let s = &mut made.summary;
        let run = &mut s.run;
        (run.format, run.seed, run.preset) = (1, seed, experiment.to_string());
        (run.config_hash, run.final_hash) = ("00".into(), "ff".into());
        (run.sim_time_s, run.robots, run.records) = (sim_time_s, 15, 1000);
        s.wall_s = 10.0 + r.uniform();
        s.log_bytes = 12345;
        let world = &mut run.world;
        (world.collisions, world.mean_neighbours) = (0, 5.0);
        world.samples_per_robot_per_600s = 20.0;
        world.samples_per_robot_per_600s_std = 1.0;
        world.trajectories_discarded = 0;
        run.byzantine.kind = if byzantine == 0 {
            ByzantineKind::None
        } else {
            ByzantineKind::Faulty
        };
        run.byzantine.count = byzantine;
        run.byzantine.robots = (0..byzantine).collect();
        let ledger = &mut run.ledger;
        (ledger.canonical_height, ledger.forks) = (498, 12);
        (ledger.reorgs, ledger.deepest_reorg) = (30, 2);
        (ledger.tx_delay_median_s, ledger.tx_delay_p95_s) = (1.2, 8.0);
        (ledger.bytes_per_submission, ledger.chain_bytes) = (16000.0, chain);
        let c = &mut run.contract;
        c.rounds = rounds as u64;
        c.final_loss = losses.last().copied();
        (c.round_times_s, c.loss_by_round) = (times, losses);
        (c.heldout_loss_by_round, c.final_heldout_loss) = (heldout, None);
        c.heldout_loss_initial = f64::NAN;
        c.submissions = [
            ("accepted", 700),
            ("outlier", 10),
            ("duplicate", 0),
            ("insufficient_stake", 3),
            ("malformed", 0),
        ]
        .map(|(k, n)| (k.to_string(), n))
        .into();
        let tokens = &mut run.tokens;
        (tokens.total_units_start, tokens.total_units_end) = (315000000000, 315000000000);
        tokens.honest_mean_gain = Some(1.5 + r.uniform());
        tokens.byzantine_mean_gain = (byzantine != 0).then(|| -4.0 + r.uniform());
        tokens.balances = vec![21.0; 15];
        tokens.byzantine_control = (byzantine >= 5).then(|| ControlPoint {
            height: 100,
            time_s: 1000.0 + r.uniform(),
            share: 0.6,
            heldout_loss: 0.05,
        });
        s.timing = Timing {
            world_s: 1.0,
            learning_s: 30.0,
            ledger_s: 2.0,
            ..Timing::default()
        };
        made.sweep = SweepTask {
            experiment: experiment.to_string(),
            point: String::new(),
            seed,
            task: 0,
            overrides: Vec::new(),
            preset: experiment.to_string(),
            point_index: 0,
            x: Some(x),
        };
        made
    }

    /// Writes a synthetic sweep result directory: `runs` seeds per point of each experiment.
    fn synthetic_dir(dir: &Path, experiments: &[&str], runs: u64) {
        for name in experiments {
            let exp = experiments::experiment(name).unwrap();
            for p in &exp.points {
                for seed in 1..=runs {
                    let path = results::result_path(dir, name, &p.name, seed);
                    results::write_atomic(&path, &synthetic_summary(name, p.x, seed)).unwrap();
                }
            }
        }
    }

    fn temp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("swarmfl-report-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn round_majorities_are_averaged_over_the_runs_that_count_them() {
        let dir = temp("majority");
        let name = "e2-malicious";
        let point = &experiments::experiment(name).unwrap().points[4];
        assert_eq!(point.x, 4.0);
        // Seeds 1 and 2 count 10 and 20 majority rounds; seed 3's summary predates the count.
        for (seed, majority) in [(1, Some(10)), (2, Some(20)), (3, None)] {
            let mut file = synthetic_summary(name, point.x, seed);
            let c = &mut file.summary.run.contract;
            c.rounds = 40;
            c.byzantine_majority_rounds = majority;
            let path = results::result_path(&dir, name, &point.name, seed);
            results::write_atomic(&path, &file).unwrap();
        }
        let out = dir.join("report");
        report(&dir, &out).unwrap();
        let md = std::fs::read_to_string(out.join("report.md")).unwrap();
        let line = format!("| {} | 2 | 0.375 ± ", point.name);
        assert!(md.contains(&line), "no `{line}` in:\n{md}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn paper_figures_are_print_sized_with_vector_text_and_filled_bands() {
        let dir = temp("style");
        synthetic_dir(&dir, &["e2-faulty"], 3);
        let out = dir.join("report");
        report(&dir, &out).unwrap();
        // The PNG at twice the 900 px (7 inch) layout: about 260 dpi in print.
        let png = std::fs::read(out.join("e2-faulty-loss.png")).unwrap();
        let width = u32::from_be_bytes(png[16..20].try_into().unwrap());
        assert_eq!(width, 1800, "PNG width");
        // The SVG is vector text whose printed size, the 900 px layout at 7 inches, is 9 pt
        // or more: an em of 16.07 px. plotters writes a font's em into `font-size`.
        let svg = std::fs::read_to_string(out.join("e2-faulty-loss.svg")).unwrap();
        assert!(svg.contains("width=\"900\""), "SVG width");
        assert_prints_at_least_9_pt(&svg, "the loss figure");
        // Confidence bands are filled, translucent polygons, not thin lines.
        let bands = svg
            .split("<polygon")
            .skip(1)
            .filter(|p| {
                let head = p.split('>').next().unwrap_or("");
                head.contains("opacity=\"0.") && head.contains("fill=\"#")
            })
            .count();
        assert!(bands >= 1, "no filled translucent band in the loss figure");
        // A heatmap's names and cell numbers too.
        let map = heatmap::Heatmap {
            title: "final loss".into(),
            row_title: "aggregation rule".into(),
            col_title: "attack".into(),
            value_title: "loss".into(),
            rows: vec!["centered-clipping".into(), "fedavg".into()],
            cols: vec!["none".into(), "inflate-samples".into(), "malicious".into()],
            values: vec![
                vec![Some(2.19), Some(8.77), None],
                vec![Some(0.0123), Some(-0.5), Some(2.2)],
            ],
            diverging: false,
            labels: Vec::new(),
            shared_scale: None,
        };
        heatmap::draw(&map, &out, "map").unwrap();
        let svg = std::fs::read_to_string(out.join("map.svg")).unwrap();
        assert!(
            svg.contains(">2.19<") || svg.contains("2.19"),
            "cell numbers drawn"
        );
        assert_prints_at_least_9_pt(&svg, "the heatmap");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Every `font-size` of `svg` (an em, in px of the 900 px = 7 inch layout) prints at 9 pt
    /// or more.
    fn assert_prints_at_least_9_pt(svg: &str, what: &str) {
        let ems: Vec<f64> = svg
            .split("font-size=\"")
            .skip(1)
            .filter_map(|t| t.split('"').next()?.trim_end_matches("px").parse().ok())
            .collect();
        assert!(!ems.is_empty(), "no text in {what}");
        let px_per_pt = 900.0 / (7.0 * 72.0);
        let smallest = ems.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(
            smallest / px_per_pt >= 9.0 - 1e-6,
            "{what}: smallest em {smallest:.2} px prints at {:.2} pt (under 9 pt); ems {ems:?}",
            smallest / px_per_pt
        );
    }

    #[test]
    fn report_numbers_do_not_depend_on_file_order_or_sharding() {
        let dir = temp("order");
        synthetic_dir(&dir, &["e1-expiration", "e2-faulty"], 3);
        let (results, notes) = load(&dir).unwrap();
        assert!(notes.is_empty(), "{notes:?}");
        assert_eq!(results.len(), (5 + 8) * 3);
        let reference = numbers_csv(&aggregate(&results));
        // Any other order of the same results gives the same numbers once sorted.
        let mut shuffled = results.clone();
        shuffled.reverse();
        shuffled.rotate_left(7);
        sort(&mut shuffled);
        assert_eq!(numbers_csv(&aggregate(&shuffled)), reference);
        // Three shards (`--shard I/3`: the tasks with index % 3 == I) write their shares into
        // separate directories; merged they are the same.
        let merged = temp("merged");
        for index in 0..3 {
            for name in ["e1-expiration", "e2-faulty"] {
                let exp = experiments::experiment(name).unwrap();
                for t in experiments::tasks(&exp, 3, &[])
                    .iter()
                    .filter(|t| t.index % 3 == index)
                {
                    let from = results::result_path(&dir, name, &t.point, t.seed);
                    let to = results::result_path(&merged, name, &t.point, t.seed);
                    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
                    std::fs::copy(from, to).unwrap();
                }
            }
        }
        let (merged_results, _) = load(&merged).unwrap();
        assert_eq!(numbers_csv(&aggregate(&merged_results)), reference);
        let (numbers, series) = &reference;
        assert!(numbers.contains("e2-faulty,byzantine-7,7,3,byzantine_gain,"));
        assert!(
            series
                .lines()
                .filter(|l| l.starts_with("e1-expiration,expiration-250,loss,"))
                .count()
                == 50
        );
        std::fs::remove_dir_all(&dir).unwrap();
        std::fs::remove_dir_all(&merged).unwrap();
    }

    #[test]
    fn aggregation_follows_the_definition() {
        // Two runs by hand: loss at t = 100 is the mean of the last closed rounds.
        let mk = |seed: u64, times: Vec<f64>, losses: Vec<f64>, gain: f64| {
            let mut made = synthetic_summary("e2-faulty", 2.0, seed);
            let run = &mut made.summary.run;
            run.sim_time_s = 300.0;
            run.contract.final_loss = losses.last().copied();
            (run.contract.round_times_s, run.contract.loss_by_round) = (times, losses);
            run.tokens.honest_mean_gain = Some(gain);
            RunResult {
                experiment: "e2-faulty".into(),
                point: "byzantine-2".into(),
                seed,
                result: made,
            }
        };
        let results = vec![
            mk(1, vec![50.0, 150.0], vec![0.4, 0.2], 1.0),
            mk(2, vec![120.0, 250.0], vec![0.6, 0.1], 3.0),
        ];
        let stats = aggregate(&results);
        let p = &stats[0].points[0];
        assert_eq!(p.x, 2.0);
        let loss: Vec<(f64, usize, f64)> = p.loss.iter().map(|(t, s)| (*t, s.n, s.mean)).collect();
        assert_eq!(
            loss,
            vec![
                (100.0, 1, 0.4),
                (200.0, 2, 0.4),
                (300.0, 2, 0.15000000000000002)
            ]
        );
        let gain = p.metrics["honest_gain"];
        assert_eq!((gain.n, gain.mean), (2, 2.0));
        assert_eq!(p.metrics["final_loss"].mean, 0.15000000000000002);
    }

    #[test]
    fn a_summary_without_a_section_is_refused_naming_the_file_and_the_section() {
        let dir = temp("partial");
        let path = results::result_path(&dir, "e1-faulty", "faulty-1", 1);
        let json = crate::summary::to_json(&synthetic_summary("e1-faulty", 1.0, 1)).unwrap();
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, json.replace("\"contract\"", "\"contracts\"")).unwrap();
        let err = report(&dir, &dir.join("report")).unwrap_err().to_string();
        assert!(
            err.contains("faulty-1/seed1.json: a JSON file, but not a result file this version reads: missing field `contract`"),
            "{err}"
        );
        assert!(!dir.join("report/report.md").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn damaged_and_mixed_results_are_refused_naming_the_files() {
        let dir = temp("refused");
        synthetic_dir(&dir, &["e2-faulty"], 2);
        let broken = dir.join("e2-faulty/byzantine-3/seed2.json");
        std::fs::write(&broken, "{\"seed\": 2, \"contr").unwrap();
        let wrong = dir.join("e2-faulty/byzantine-1/seed1.json");
        std::fs::write(&wrong, "{\"seed\": 9}").unwrap();
        let err = report(&dir, &dir.join("report")).unwrap_err().to_string();
        assert!(err.contains("2 result file(s)"), "{err}");
        assert!(
            err.contains("byzantine-3/seed2.json: not readable as JSON"),
            "{err}"
        );
        assert!(err.contains("byzantine-1/seed1.json: a JSON file"), "{err}");
        assert!(!dir.join("report/report.md").exists());
        synthetic_dir(&dir, &["e2-faulty"], 2);
        // seed 3 of one point made at another duration: refused, both settings named.
        let mut other = synthetic_summary("e2-faulty", 2.0, 3);
        other.summary.run.config_hash = "1234567890abcdef".into();
        other.sweep.overrides = vec!["byzantine.count=2".into(), "run.duration_s=200".into()];
        results::write_atomic(
            &results::result_path(&dir, "e2-faulty", "byzantine-2", 3),
            &other,
        )
        .unwrap();
        let err = report(&dir, &dir.join("report")).unwrap_err().to_string();
        assert!(err.contains("e2-faulty byzantine-2 mixes results"), "{err}");
        assert!(
            err.contains("seed1.json was made with no --set (configuration 00)"),
            "{err}"
        );
        assert!(
            err.contains("seed3.json with --set run.duration_s=200 (configuration 1234567890ab)"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The text of every `<text>` element of an SVG (plotters writes each on a line of its
    /// own).
    fn svg_texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| t.split_once('>')?.1.split_once("</text>"))
            .map(|(inside, _)| inside.trim().to_string())
            .collect()
    }

    #[test]
    fn a_grid_over_a_text_key_and_a_count_is_drawn_and_tabled_by_its_values() {
        // The sweep: --grid contract.rule=median,krum --grid byzantine.count=1,3.
        let dir = temp("two-key-grid");
        let axes = [
            crate::grid::parse_axis("contract.rule=median,krum").unwrap(),
            crate::grid::parse_axis("byzantine.count=1,3").unwrap(),
        ];
        let set = ["run.duration_s=300".to_string()];
        let exp = crate::grid::experiment("smoke", &axes, &set).unwrap();
        for (index, p) in exp.points.iter().enumerate() {
            let count: f64 = p.name.rsplit('=').next().unwrap().parse().unwrap();
            for seed in 1..=2 {
                let mut s = synthetic_summary(&exp.name, count, seed);
                let mut overrides = p.overrides.clone();
                overrides.extend(set.iter().cloned());
                s.sweep = SweepTask {
                    experiment: exp.name.clone(),
                    overrides,
                    point: p.name.clone(),
                    point_index: index,
                    preset: "smoke".into(),
                    seed,
                    task: 0,
                    x: Some(p.x).filter(|x| x.is_finite()),
                };
                let path = results::result_path(&dir, &exp.name, &p.name, seed);
                results::write_atomic(&path, &s).unwrap();
            }
        }
        let out = dir.join("report");
        let files = make(&dir, &out).unwrap();
        let md = std::fs::read_to_string(out.join("report.md")).unwrap();
        // A column per key, showing the values.
        assert!(
            md.contains("| point | contract.rule | byzantine.count | runs |"),
            "{md}"
        );
        assert!(
            md.contains("| contract.rule=krum+byzantine.count=3 | krum | 3 | 2 |"),
            "{md}"
        );
        // Over time: a line per combination, named key=value.
        let loss = svg_texts(&std::fs::read_to_string(out.join("grid-smoke-loss.svg")).unwrap());
        for label in [
            "contract.rule=median, byzantine.count=1",
            "contract.rule=median, byzantine.count=3",
            "contract.rule=krum, byzantine.count=1",
            "contract.rule=krum, byzantine.count=3",
        ] {
            assert!(loss.iter().any(|t| t == label), "{label} in {loss:?}");
        }
        assert!(!loss.iter().any(|t| t.contains("Byzantine")), "{loss:?}");
        // Versus the count, its values as the ticks; a pair of series per rule.
        let tokens =
            svg_texts(&std::fs::read_to_string(out.join("grid-smoke-tokens.svg")).unwrap());
        assert!(tokens.iter().any(|t| t == "byzantine.count"), "{tokens:?}");
        for label in [
            "honest robots, contract.rule=median",
            "Byzantine robots, contract.rule=krum",
        ] {
            assert!(tokens.iter().any(|t| t == label), "{label} in {tokens:?}");
        }
        // plotters writes the y ticks, then the x ticks, then the legend: the x axis is
        // marked at 1 and 3 only.
        let legend = tokens
            .iter()
            .position(|t| t.starts_with("honest robots"))
            .unwrap();
        assert_eq!(tokens[legend - 2..legend], ["1", "3"], "{tokens:?}");
        assert!(
            tokens[legend - 3].parse::<f64>().unwrap() > 1.0,
            "{tokens:?}"
        );
        // Every file written is listed, report.md last.
        let mut on_disk: Vec<PathBuf> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        on_disk.sort();
        let mut listed = files.clone();
        listed.sort();
        assert_eq!(listed, on_disk);
        assert_eq!(files.last(), Some(&out.join("report.md")));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_full_synthetic_report_draws_every_figure() {
        let dir = temp("full");
        synthetic_dir(&dir, &EXPERIMENTS, 3);
        let out = dir.join("report");
        let md = std::fs::read_to_string(report(&dir, &out).unwrap()).unwrap();
        for stem in [
            "e1-expiration-loss",
            "e1-faulty-loss",
            "e2-faulty-loss",
            "e2-faulty-tokens",
            "e2-malicious-tokens",
            "e3-smart-loss",
            "e3-smart-tokens",
            "e2-faulty-chain",
            "e5-smart-defence-smart-tokens",
            "e5-smart-defence-smart-heldout",
            "e5-smart-defence-switch-tokens",
            "e5-smart-defence-switch-heldout",
            "e6-scale-heldout-15",
            "e6-scale-heldout-240",
            "e6-scale-heldout-1000",
            "e6-scale-final-heldout",
            "e6-scale-versions",
            "e6-scale-wall",
        ] {
            for ext in ["svg", "png"] {
                let f = out.join(format!("{stem}.{ext}"));
                let len = std::fs::metadata(&f).map(|m| m.len()).unwrap_or(0);
                assert!(len > 1000, "{} is missing or empty", f.display());
            }
            assert!(
                md.contains(&format!("({stem}.png)")),
                "{stem} is not in report.md"
            );
        }
        assert!(
            md.contains("| agreement--smart-then-collude--7 | 3 | 3 | 10"),
            "the control table of e5"
        );
        // e6's table, once, in e6-scale's section; the standard loss figure is not drawn.
        assert_eq!(
            md.matches("| point | robots | faulty | runs | versions |")
                .count(),
            1
        );
        assert!(
            md.contains("| buffered-1000 | 1000 |"),
            "e6-scale-1000 in the table"
        );
        assert!(!out.join("e6-scale-loss.png").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

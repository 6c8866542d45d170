use super::*;
use crate::sweep::{sweep, Shard, SweepOptions};

/// The experiment the report draws.
fn experiment() -> &'static str {
    let entry = experiments::ALL
        .iter()
        .find(|e| Heterogeneity.draws(Some(e)));
    entry
        .expect("an experiment drawn by the heterogeneity report")
        .name()
}

/// A run of `point` with the genesis held-out loss `genesis` and the final one `last`.
fn result(point: &str, seed: u64, genesis: f64, last: f64) -> RunResult {
    let mut result = crate::summary::tests::example();
    let c = &mut result.summary.run.contract;
    c.final_heldout_loss = Some(last);
    c.heldout_loss_initial = genesis;
    RunResult {
        experiment: experiment().to_string(),
        point: point.to_string(),
        seed,
        result,
    }
}

/// Fractions of genesis, worst case, destroyed runs with their interval, the per-seed table
/// and the clean FedAvg's verdict, by hand (values exact in binary).
#[test]
fn fractions_worst_cases_destroyed_runs_and_seeds_match_hand_computed_cells() {
    let mut results = Vec::new();
    // Two alphas, genesis 4 roaming and 2 at 0.1; seeds 1 to 3.
    for (alpha, genesis) in [("inf", 4.0), ("0.1", 2.0)] {
        for seed in 1..=3u64 {
            let k = seed as f64;
            let p = |rule: &str, attack: &str, count: u32| {
                format!("alpha-{alpha}--{rule}--{attack}--{count}")
            };
            // FedAvg clean ends at 1/8, 2/8, 3/8 of genesis roaming; at 0.1 at 5/8, 6/8, 7/8.
            let clean = if alpha == "inf" {
                k / 8.0
            } else {
                (4.0 + k) / 8.0
            };
            results.push(result(
                &p("fedavg", "none", 0),
                seed,
                genesis,
                clean * genesis,
            ));
            // Median at 5: IPM destroys seed 1's model only; ALIE ends at half of genesis.
            let ipm = if seed == 1 { 1e9 } else { genesis / 4.0 };
            results.push(result(&p("median", "optimal-ipm", 5), seed, genesis, ipm));
            results.push(result(
                &p("median", "optimal-alie", 5),
                seed,
                genesis,
                genesis / 2.0,
            ));
        }
    }
    let h = study(&results, experiment()).unwrap();
    assert_eq!(h.alphas, ["inf", "0.1"]);
    assert_eq!(h.rules, ["fedavg", "median"]);
    assert_eq!(h.counts, [0, 5]);
    assert_eq!(h.seeds(), [1, 2, 3]);
    let w = h.worst("median", "0.1", 5).unwrap();
    assert_eq!(w.cell.attack, "optimal-ipm");
    assert_eq!(w.mean, (5e8 + 0.25 + 0.25) / 3.0);
    assert_eq!(h.destroyed("median", "0.1", 5), (1, 6));
    assert_eq!(h.destroyed("fedavg", "inf", 0), (0, 3));
    assert_eq!(h.worst("fedavg", "0.1", 0).unwrap().mean, 0.75);
    let md = tables::markdown(&h);
    // 1 of 6: Wilson 95 % 3.0 % to 56.4 %.
    assert!(
        md.contains("| median | 1/6 [3-56 %] | 1/6 [3-56 %] |"),
        "{md}"
    );
    assert!(
        md.contains("| median | 0.1 | n/a | optimal-ipm, 1.67e8 (0.2500 / 0.2500 / 5.00e8) |"),
        "{md}"
    );
    // Seed 1 holds both destroyed runs.
    assert!(md.contains("| 1 | 1/2 | 1/2 | 2/4 |"), "{md}");
    assert!(md.contains("| 2 | 0/2 | 0/2 | 0/4 |"), "{md}");
    assert!(
        md.contains("| inf (roaming) | 4.000 | 0.1250 / 0.2500 / 0.3750 | 3 of 3 |"),
        "{md}"
    );
    assert!(
        md.contains("ends at 0.7500 of its genesis held-out loss (median of 3 seeds): it does not learn. Learning stops (median above 0.5 of genesis) from alpha 0.1 on."),
        "{md}"
    );
    let cells = tables::cells_csv(&h);
    assert_eq!(cells.lines().count(), 1 + 2 * 2 + 2 * 2 - 4, "{cells}");
    assert!(
        cells.contains("median,0.1,5,optimal-ipm,1.6666666683333334e8,2.5e-1,2.5e-1,5e8,1,6,"),
        "{cells}"
    );
    let runs = tables::runs_csv(&h);
    assert_eq!(runs.lines().count(), 1 + results.len());
    assert!(
        runs.contains("0.1,median,optimal-ipm,5,1,2e0,1e9,5e8,true"),
        "{runs}"
    );
}

/// The threshold's table: per threshold rule and alpha, the clean runs' outliers of the counted
/// submissions, the honest distances' spread and largest round mean, and the verdict summed
/// over the table; attacked runs and other rules stay out of it.
#[test]
fn the_threshold_table_counts_the_clean_runs_honest_outliers() {
    let mut results = Vec::new();
    for (alpha, outliers) in [("inf", 0u64), ("0.1", 3)] {
        for seed in 1..=2u64 {
            for (point, distance) in [
                (
                    format!("alpha-{alpha}--paper--none--0"),
                    0.002 * seed as f64,
                ),
                (format!("alpha-{alpha}--gate+median--none--0"), 0.001),
                (format!("alpha-{alpha}--fedavg--none--0"), 0.5),
                (format!("alpha-{alpha}--paper--optimal-ipm--5"), 0.5),
            ] {
                let mut r = result(&point, seed, 2.0, 1.0);
                let c = &mut r.result.summary.run.contract;
                c.submissions = [("accepted".to_string(), 90), ("aggregated".to_string(), 10)]
                    .into_iter()
                    .collect();
                if point.contains("paper--none") && seed == 2 && outliers > 0 {
                    c.submissions.insert("outlier".to_string(), outliers);
                }
                c.mean_honest_distance = Some(distance);
                c.mean_honest_distance_by_round = vec![distance, f64::NAN, 2.0 * distance];
                c.outlier_threshold = 0.05;
                results.push(r);
            }
        }
    }
    let h = study(&results, experiment()).unwrap();
    let md = tables::markdown(&h);
    assert!(
        md.contains(
            "| paper | inf (roaming) | 0 / 200 | 0.0020 / 0.0030 / 0.0040 | 0.0080 | 0.0500 |"
        ),
        "{md}"
    );
    assert!(
        md.contains("| paper | 0.1 | 3 / 203 | 0.0020 / 0.0030 / 0.0040 | 0.0080 | 0.0500 |"),
        "{md}"
    );
    assert!(
        md.contains("| gate+median | 0.1 | 0 / 200 | 0.0010 / 0.0010 / 0.0010 | 0.0020 | 0.0500 |"),
        "{md}"
    );
    assert!(!md.contains("| fedavg | inf (roaming) | 0 / 200"), "{md}");
    assert!(
        md.contains(
            "Of 803 honest submissions in these clean runs, the threshold rejected 3 (0.37 %). \
             The largest round mean of the honest distances, 0.0080, is 0.160 of the threshold \
             (0.0500)."
        ),
        "{md}"
    );
}

/// The report's whole path on two real (short) runs of the grid: a sweep of two of its
/// tasks, then `report::make`, which must draw the section, the maps and both CSV files from
/// what the runs wrote.
#[test]
fn a_two_run_sweep_of_the_grid_makes_the_report() {
    let dir = std::env::temp_dir().join(format!("swarmfl-hetero-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let exp = experiments::experiment(experiment()).unwrap();
    // One seed: task i is point i. Shard 96/163 takes points 96 and 259.
    let (a, b) = (&exp.points[96], &exp.points[259]);
    assert_eq!(a.name, "alpha-10--geomed--optimal-alie--5");
    assert_eq!(b.name, "alpha-0.1--fedavg--none--0");
    let opts = SweepOptions {
        experiment: Some(experiment().to_string()),
        preset: None,
        grid: Vec::new(),
        out: dir.join("results"),
        runs: Some(1),
        jobs: Some(1),
        shard: Shard::new(96, 163).unwrap(),
        overrides: vec!["run.duration_s=400".into()],
        keep_logs: false,
    };
    let done = sweep(&opts, &crate::progress::Quiet, None).unwrap();
    assert_eq!((done.ran, done.failed.len()), (2, 0));
    let files = crate::report::make(&dir.join("results"), &dir.join("report")).unwrap();
    let name = |f: &str| dir.join("report").join(f);
    for f in [
        "e4-heterogeneity-cells.csv",
        "e4-heterogeneity-runs.csv",
        "e4-heterogeneity-byzantine-0.svg",
        "e4-heterogeneity-byzantine-5.svg",
    ] {
        assert!(files.contains(&name(f)), "{f} not in {files:?}");
    }
    let md = std::fs::read_to_string(name("report.md")).unwrap();
    assert!(md.contains("2 runs read, seeds 1."), "{md}");
    assert!(md.contains("### Does a clean FedAvg still learn?"), "{md}");
    assert!(
        md.contains("At the lowest alpha (0.1) a clean FedAvg run ends at"),
        "{md}"
    );
    // Each run's fraction is its own final over its own genesis.
    let runs = std::fs::read_to_string(name("e4-heterogeneity-runs.csv")).unwrap();
    let (results, _) = super::super::load::load(&dir.join("results")).unwrap();
    for r in &results {
        let c = &r.result.summary.run.contract;
        let last = c.final_heldout_loss.unwrap();
        let fraction = format!("{:e},", last / c.heldout_loss_initial);
        assert!(runs.contains(&fraction), "{fraction} not in {runs}");
    }
    assert_eq!(runs.lines().count(), 3, "{runs}");
    let _ = std::fs::remove_dir_all(&dir);
}

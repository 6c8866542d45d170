use super::super::load::sort;
use super::super::tables::numbers_csv;
use super::*;

/// A run's summary with the fields the study reads set (every other one a reduced-study
/// run's): `rounds` versions at 150 s steps whose held-out losses fall to `heldout`
/// (`None`: no version), from the genesis model's 3.0.
fn run(
    point: &str,
    seed: u64,
    faulty: u32,
    heldout: Option<f64>,
    submissions: &[(&str, u64)],
) -> RunResult {
    let rounds = if heldout.is_some() { 2u64 } else { 0 };
    let times: Vec<f64> = (1..=rounds).map(|k| k as f64 * 150.0).collect();
    let losses: Vec<f64> = (0..rounds)
        .map(|k| heldout.unwrap_or(0.0) * (rounds - k) as f64)
        .collect();
    let mut result = crate::summary::tests::example();
    let s = &mut result.summary;
    (s.run.seed, s.run.sim_time_s, s.run.robots) = (seed, 300.0, 240);
    s.wall_s = 10.0 * seed as f64;
    s.run.byzantine.kind = if faulty > 0 {
        ByzantineKind::Faulty
    } else {
        ByzantineKind::None
    };
    s.run.byzantine.count = faulty;
    let c = &mut s.run.contract;
    (c.rounds, c.round_times_s, c.heldout_loss_by_round) = (rounds, times, losses);
    (c.heldout_loss_initial, c.final_heldout_loss) = (3.0, heldout);
    c.submissions = submissions
        .iter()
        .map(|(k, n)| (k.to_string(), *n))
        .collect();
    (c.aggregated_honest, c.aggregated_byzantine) = (14, 0);
    s.run.tokens.byzantine_mean_gain = (faulty > 0).then_some(-5.0);
    s.run.aggregation.bytes_sent_per_robot_mean = 2.0e6 * seed as f64;
    s.run.aggregation.bytes_stored_per_robot_mean = 1.0e6 * seed as f64;
    RunResult {
        experiment: "e6-scale".into(),
        point: point.into(),
        seed,
        result,
    }
}

/// rounds-240 (one seed that made no version), buffered-240 (seeds 1 to 3) and
/// buffered-240-faulty-24 (seeds 1 and 2, one faulty model aggregated in seed 2), in
/// file order, not grid order.
fn results() -> Vec<RunResult> {
    let clean = [("accepted", 10), ("aggregated", 2), ("stale", 1)];
    let hostile = [
        ("accepted", 10),
        ("aggregated", 2),
        ("outlier", 6),
        ("stale", 4),
        ("unknown_base", 1),
        ("duplicate_base", 2),
    ];
    let mut faulty = run("buffered-240-faulty-24", 2, 24, Some(0.02), &hostile);
    let contract = &mut faulty.result.summary.run.contract;
    (contract.aggregated_honest, contract.aggregated_byzantine) = (13, 1);
    let mut results = vec![
        faulty,
        run("buffered-240", 1, 0, Some(0.02), &clean),
        run("buffered-240", 2, 0, Some(0.04), &clean),
        run("buffered-240", 3, 0, Some(0.09), &clean),
        run("buffered-240-faulty-24", 1, 24, Some(0.03), &hostile),
        run(
            "rounds-240",
            1,
            0,
            None,
            &[("accepted", 200), ("outlier", 50)],
        ),
    ];
    sort(&mut results);
    results
}

#[test]
fn the_tables_hold_the_hand_computed_numbers() {
    let rows = study(&results());
    let names: Vec<&str> = rows.iter().map(|r| r.point.as_str()).collect();
    assert_eq!(
        names,
        ["rounds-240", "buffered-240", "buffered-240-faulty-24"]
    );
    let faulty = &rows[2];
    assert_eq!(
        (faulty.protocol.as_str(), faulty.robots, faulty.faulty),
        ("buffered", 240.0, 24)
    );
    // Paired by seed: 0.03 / 0.02 and 0.02 / 0.04 (a ratio of means would be 0.83).
    let ratio = &faulty.ratio_to_clean;
    assert_eq!(ratio.len(), 2);
    assert!(
        (ratio[0] - 1.5).abs() < 1e-12 && (ratio[1] - 0.5).abs() < 1e-12,
        "{ratio:?}"
    );
    let r = faulty.runs[0].clone();
    // accepted 10 + aggregated 2; unknown_base 1 + duplicate_base 2 are the other refusals.
    assert_eq!(
        (
            r.accepted,
            r.outlier,
            r.stale,
            r.refused,
            r.aggregated,
            r.faulty_aggregated
        ),
        (
            Some(12.0),
            Some(6.0),
            Some(4.0),
            Some(3.0),
            Some(14.0),
            Some(0.0)
        )
    );
    let md = section(&rows);
    // A run without a version keeps the genesis model's loss, 3.0.
    assert!(
        md.contains("| rounds-240 | 240 | 0 | 1 | 0.0 | 3.00000 | 1.0000 | 200.0 | 50.0 | 0.0 | 0.0 | 2.00 | 1.00 | 10.0 |"),
        "{md}"
    );
    // Held-out 0.02, 0.04, 0.09: mean 0.05, sd sqrt(0.0013) = 0.03606. Sent 2, 4, 6 MB;
    // stored 1, 2, 3; wall 10, 20, 30 s. Of the genesis model's 3.0: 0.05 / 3 = 0.0167,
    // sd 0.03606 / 3 = 0.0120.
    assert!(
        md.contains("| buffered-240 | 240 | 0 | 3 | 2.0 ± 0.0 | 0.05000 ± 0.03606 | 0.0167 ± 0.0120 | 12.0 ± 0.0 | 0.0 ± 0.0 | 1.0 ± 0.0 | 0.0 ± 0.0 | 4.00 ± 2.00 | 2.00 ± 1.00 | 20.0 ± 10.0 |"),
        "{md}"
    );
    // Faulty models aggregated 0 and 1: mean 0.5, sd 0.71; held-out 0.03, 0.02: 0.025 ±
    // 0.00707; ratios 1.5 and 0.5: 1.00 ± 0.71, worst 1.50.
    assert!(
        md.contains("| buffered-240-faulty-24 | 2 | 0.5 ± 0.7 | 14.0 ± 0.0 | -5.00 ± 0.00 | 0.02500 ± 0.00707 | buffered-240 | 0.05000 ± 0.03606 | 1.00 ± 0.71 | 1.50 |"),
        "{md}"
    );
}

#[test]
fn the_study_numbers_reach_the_csv_files_and_curves_start_at_genesis() {
    let results = results();
    let rows = study(&results);
    let mut stats = stats::aggregate(&results);
    extend(&mut stats, &rows);
    let points = &stats[0].points;
    let curve = |point: &str| -> Vec<(f64, usize, f64)> {
        let p = points.iter().find(|p| p.point == point).unwrap();
        p.heldout.iter().map(|(t, s)| (*t, s.n, s.mean)).collect()
    };
    // At 100 s no run has a version: the genesis model's 3.0 in every run. At 200 s the
    // first versions, 2 x (0.02, 0.04, 0.09); at 300 s the last.
    let buffered = curve("buffered-240");
    assert_eq!(buffered.len(), 3);
    assert_eq!(
        (buffered[0].0, buffered[0].1, buffered[0].2),
        (100.0, 3, 3.0)
    );
    assert!((buffered[1].2 - 0.1).abs() < 1e-12, "{buffered:?}");
    assert!((buffered[2].2 - 0.05).abs() < 1e-12, "{buffered:?}");
    assert_eq!(
        curve("rounds-240"),
        [(100.0, 1, 3.0), (200.0, 1, 3.0), (300.0, 1, 3.0)]
    );
    let (numbers, series) = numbers_csv(&stats);
    let row = |metric: &str, point: &str| {
        numbers
            .lines()
            .find(|l| {
                l.starts_with(&format!("e6-scale,{point},240,"))
                    && l.contains(&format!(",{metric},"))
            })
            .map(str::to_string)
    };
    let ratio = row("heldout_ratio_to_clean", "buffered-240-faulty-24").expect("ratio row");
    // (1.5 + 0.5) / 2, with its 95 % half-width: t(1) x sd / sqrt(2) = 12.706 x 0.5.
    assert!(
        ratio.contains(",2,heldout_ratio_to_clean,1e0,6.353e0,"),
        "{ratio}"
    );
    assert!(row("heldout_loss_end", "rounds-240")
        .is_some_and(|l| l.contains(",1,heldout_loss_end,3e0,")));
    assert!(
        row("submissions_refused", "buffered-240-faulty-24").is_some_and(|l| l.contains(",3e0,"))
    );
    // Faulty models are counted only where there are faulty robots.
    assert!(row("faulty_models_aggregated", "buffered-240").is_none());
    assert!(
        series.contains("e6-scale,rounds-240,heldout_loss,100,1,3e0,"),
        "{series}"
    );
}

#[test]
fn the_figures_are_drawn_under_the_first_experiment_of_the_study() {
    let dir = std::env::temp_dir().join(format!("swarmfl-scale-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let results = results();
    let rows = study(&results);
    let mut stats = stats::aggregate(&results);
    extend(&mut stats, &rows);
    let mut notes = Vec::new();
    let figures = draw_all(&stats, &rows, &dir, &mut notes).unwrap();
    let stems: Vec<&str> = figures.iter().map(|f| f.stem.as_str()).collect();
    assert_eq!(
        stems,
        [
            "e6-scale-heldout-240",
            "e6-scale-final-heldout",
            "e6-scale-final-heldout-of-genesis",
            "e6-scale-versions",
            "e6-scale-sent",
            "e6-scale-stored",
            "e6-scale-wall"
        ]
    );
    assert!(figures.iter().all(|f| f.experiment == "e6-scale"));
    assert_eq!(home(&rows), Some("e6-scale"));
    for stem in stems {
        let len = std::fs::metadata(dir.join(format!("{stem}.png"))).map_or(0, |m| m.len());
        assert!(len > 1000, "{stem}.png");
    }
    assert!(study(&[]).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The chain against its matched ideal (issue 56): per seed, the buffered run's median
/// over the last 1000 s over the matched run's, both as fractions of genesis; and the age and
/// propagation table from the new summary sections.
#[test]
fn the_matched_table_divides_the_chain_by_its_ideal_per_seed() {
    use swarmfl_core::ledger::metrics::DelayStats;
    use swarmfl_core::ledger::VersionPropagation;
    use swarmfl_core::metrics::Staleness;
    let with = |point: &str, seed: u64, median: f64, ages: &[(u64, u64)]| {
        let mut r = run(point, seed, 0, Some(0.1), &[("accepted", 10)]);
        let s = &mut r.result.summary.run;
        s.contract.median_heldout_loss_last_1000s = Some(median);
        s.contract.staleness = Some(Staleness::of(ages, 0));
        s.ledger.details.version_propagation = Some(VersionPropagation {
            versions: 2,
            delay: DelayStats::of(vec![0, 4000, 8000]),
            not_reached: 0,
        });
        r
    };
    let mut all = vec![
        with(
            "buffered-240",
            1,
            0.6,
            &[(0, 1000), (1, 2000), (5, 9000), (9, 20_000)],
        ),
        with("buffered-240", 2, 0.3, &[(0, 1000)]),
        with("matched-240", 1, 0.3, &[(0, 1000)]),
        with("matched-240", 2, 0.3, &[(0, 1000)]),
    ];
    sort(&mut all);
    let rows = study(&all);
    let md = matched_table(&rows);
    // Genesis 3.0: 0.2 and 0.1 of genesis over 0.1: ratios 2 and 1, mean 1.5, worst 2.
    assert!(
        md.contains("| 240 | 0.1500 ± 0.0707 | 0.1000 ± 0.0000 | 1.50 ± 0.71 | 2.00 |"),
        "{md}"
    );
    // Seed 1 of buffered-240: 1 of 4 at age 0, 2 within 1 and 3, 3 within 7; seed 2: all 0.
    assert!(
        md.contains("| buffered-240 | 0.62 ± 0.53 | 0.75 ± 0.35 | 0.75 ± 0.35 | 0.88 ± 0.18 |"),
        "{md}"
    );
    assert!(md.contains("| 4.0 ± 0.0 | 8.0 ± 0.0 |"), "{md}");
    assert!(matched_table(&study(&results())).is_empty());
}

#[test]
fn a_faulty_point_is_judged_by_its_median_of_the_last_1000_s_where_both_runs_have_it() {
    let mut results = results();
    let set = |results: &mut Vec<RunResult>, point: &str, seed: u64, median: f64| {
        let r = results
            .iter_mut()
            .find(|r| r.point == point && r.seed == seed)
            .expect("the run");
        r.result.summary.run.contract.median_heldout_loss_last_1000s = Some(median);
    };
    // Seed 1 has both medians: 0.06 / 0.05 = 1.2, not the finals' 0.03 / 0.02 = 1.5 ...
    set(&mut results, "buffered-240-faulty-24", 1, 0.06);
    set(&mut results, "buffered-240", 1, 0.05);
    // ... seed 2 has only the faulty run's: the finals, 0.02 / 0.04.
    set(&mut results, "buffered-240-faulty-24", 2, 0.9);
    let rows = study(&results);
    let ratio = &rows[2].ratio_to_clean;
    assert_eq!(ratio.len(), 2);
    assert!(
        (ratio[0] - 1.2).abs() < 1e-12 && (ratio[1] - 0.5).abs() < 1e-12,
        "{ratio:?}"
    );
}

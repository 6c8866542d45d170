//! Hand-computed bounds of the relative outlier rule: the lower median and the clamp, the
//! window's turnover, the contract judging against the bound of its window, and adaptive
//! creep and deflation attempts by a coalition that reads the chain.

use std::sync::Arc;

use super::*;
use crate::contract::buffered::{staleness_weight, BufferedParams, STEP_SCALE};
use crate::contract::test_support::{STAKE, TOKEN};
use crate::contract::{Call, Outcome};

fn rule(factor_micro: u64, window_buffers: u32, cap_units: i64) -> RelativeOutlier {
    RelativeOutlier {
        factor_micro,
        window_buffers,
        cap_units,
    }
}

fn window(distances: &[u64]) -> Window {
    let mut w = Window::default();
    w.record(distances.iter().copied(), distances.len());
    w
}

/// `robots` accounts with 10,000 tokens, stake 5, K accepted updates per version, a 2-weight
/// model, the paper's rule with a floor of 100 units per weight (200 per model) and the
/// relative rule `outlier` (or the absolute one with `None`).
fn params(robots: u32, k: u32, outlier: Option<RelativeOutlier>) -> ContractParams {
    let mut reward_weights = vec![1; k as usize];
    reward_weights[k as usize - 1] = -1;
    ContractParams {
        initial_units: 10_000 * TOKEN,
        outlier_threshold_units: 100,
        buffered: Some(BufferedParams {
            max_staleness: 4,
            staleness_weights: (0..=4).map(|t| staleness_weight(0.5, t)).collect(),
            step_units: STEP_SCALE,
        }),
        outlier,
        ..crate::contract::test_support::params(robots, reward_weights, 2)
    }
}

/// `robot` submits the newest version plus an update of distance `d` (split over the two
/// weights), claiming one sample.
fn submit(s: &mut ContractState, p: &ContractParams, robot: u32, d: u64) -> Outcome {
    let (a, b) = ((d / 2) as i64, (d - d / 2) as i64);
    let weights: Arc<[i64]> = Arc::from(vec![s.weights[0] + a, s.weights[1] + b]);
    let call = Call::SubmitUpdate {
        weights,
        samples: 1,
        base_round: s.round,
        base_digest: s.weights_digest,
    };
    let outcome = s.execute(p, robot, STAKE, &call);
    assert_eq!(s.total_units(), p.total_units(), "tokens conserved");
    outcome
}

#[test]
fn the_bound_is_k_times_the_lower_median_between_floor_and_cap() {
    // A 4-weight model, floor 100 and cap 1000 per weight: 400 and 4000; K = 2, W = 2.
    let check = |factor_micro: u64, distances: &[u64], expect: u128| {
        let r = rule(factor_micro, 2, 1000);
        let got = r.bound_units(&window(distances), 2, 100, 4);
        assert_eq!(got, expect, "k = {factor_micro} / 10^6 over {distances:?}");
    };
    // Sorted [500, 700, 900, 3000]: the lower median is sorted[1] = 700.
    check(5_000_000, &[500, 900, 700, 3000], 3500);
    check(2_000_000, &[500, 900, 700, 3000], 1400);
    // 0.5 * 700 = 350, below the floor; 10 * 700 = 7000, above the cap.
    check(500_000, &[500, 900, 700, 3000], 400);
    check(10_000_000, &[500, 900, 700, 3000], 4000);
    // k = 1.333333: 700 * 1333333 / 10^6 = 933.33, floored.
    check(1_333_333, &[500, 900, 700, 3000], 933);
    // A window short of W * K = 4 distances holds the floor, whatever it contains.
    check(5_000_000, &[3000, 3000, 3000], 400);
    check(5_000_000, &[], 400);
}

#[test]
fn the_lower_median_and_the_window_turnover() {
    assert_eq!(window(&[]).lower_median(), None);
    assert_eq!(window(&[7]).lower_median(), Some(7));
    // Odd: the middle; even: the lower of the two middles.
    assert_eq!(window(&[9, 1, 5]).lower_median(), Some(5));
    assert_eq!(window(&[9, 1, 5, 3]).lower_median(), Some(3));
    // The window keeps the newest `len` distances in chain order.
    let mut w = window(&[1, 2, 3]);
    w.record([4, 5].into_iter(), 4);
    assert_eq!(w.distances().collect::<Vec<_>>(), [2, 3, 4, 5]);
    w.record([6, 7, 8, 9, 10].into_iter(), 4);
    assert_eq!(w.distances().collect::<Vec<_>>(), [7, 8, 9, 10]);
}

#[test]
fn the_contract_judges_against_the_bound_of_its_closed_buffers() {
    // K = 2, W = 2 (n = 4), k = 1.5, cap 400 per weight (800); floor 200.
    let p = params(10, 2, Some(rule(1_500_000, 2, 400)));
    let mut s = ContractState::genesis(&p);
    let bound = |s: &ContractState| s.outlier_bound_units(&p);
    // Version 0 (window empty: the floor): 150 and 180 accepted, 250 an outlier.
    assert_eq!(bound(&s), 200);
    assert!(submit(&mut s, &p, 0, 150).is_accepted());
    assert!(matches!(
        submit(&mut s, &p, 1, 250),
        Outcome::Outlier { round: 0, .. }
    ));
    assert!(matches!(
        submit(&mut s, &p, 2, 180),
        Outcome::Aggregated { round: 0, .. }
    ));
    // One buffer closed, W = 2 needed: still the floor; the outlier's distance is not kept.
    let b = s.buffered.as_deref().unwrap();
    assert_eq!(b.outlier_window.distances().collect::<Vec<_>>(), [150, 180]);
    assert_eq!(bound(&s), 200);
    assert!(submit(&mut s, &p, 3, 200).is_accepted());
    assert!(submit(&mut s, &p, 4, 190).is_accepted());
    // Window [150, 180, 200, 190]: lower median 180, 1.5 * 180 = 270.
    assert_eq!(s.round, 2);
    assert_eq!(bound(&s), 270);
    assert_eq!(s.outlier_bound(&p, 1), 135.0, "per weight");
    // 250, an outlier at version 0, is accepted now; 271 is beyond the bound.
    assert!(submit(&mut s, &p, 1, 250).is_accepted());
    assert!(matches!(
        submit(&mut s, &p, 5, 271),
        Outcome::Outlier { round: 2, .. }
    ));
    assert!(matches!(
        submit(&mut s, &p, 6, 270),
        Outcome::Aggregated { round: 2, .. }
    ));
    // Window [200, 190, 250, 270]: lower median 200, bound 300.
    assert_eq!(bound(&s), 300);
    // The absolute rule on the same calls: the floor throughout, the window never filled.
    let p = params(10, 2, None);
    let mut s = ContractState::genesis(&p);
    for (robot, d) in [(0, 150), (2, 180), (3, 200), (4, 190)] {
        assert!(submit(&mut s, &p, robot, d).is_accepted());
    }
    assert!(matches!(
        submit(&mut s, &p, 1, 250),
        Outcome::Outlier { .. }
    ));
    assert!(s.buffered.as_deref().unwrap().outlier_window.is_empty());
    assert_eq!(s.outlier_bound_units(&p), 200);
    assert_eq!(s.outlier_bound(&p, 1), 100.0);
}

/// A creep attempt: `coalition` robots (0..coalition) submit every version an update exactly
/// at the bound in force, which they read from their chain; the honest robots fill the rest of
/// each buffer of K = 7 with updates of distance 200 (the floor). k = 5, W = 8 (n = 56), cap
/// 10,000 per weight (20,000). Returns the bound in force at each of `versions` versions.
fn creep(coalition: u32, versions: u64) -> Vec<u128> {
    let robots = 40;
    let p = params(robots, 7, Some(rule(5_000_000, 8, 10_000)));
    let mut s = ContractState::genesis(&p);
    let mut next_honest = 0;
    let mut bounds = Vec::new();
    for v in 0..versions {
        let bound = s.outlier_bound_units(&p);
        bounds.push(bound);
        let d = u64::try_from(bound).unwrap();
        for robot in 0..coalition {
            assert!(submit(&mut s, &p, robot, d).is_accepted(), "at the bound");
        }
        // Beyond the bound by one unit: an outlier, whatever the coalition did.
        let probe = coalition + next_honest % (robots - coalition);
        next_honest += 1;
        assert!(matches!(
            submit(&mut s, &p, probe, d + 1),
            Outcome::Outlier { .. }
        ));
        for _ in coalition..7 {
            let robot = coalition + next_honest % (robots - coalition);
            next_honest += 1;
            submit(&mut s, &p, robot, 200);
        }
        assert_eq!(s.round, v + 1, "every buffer closes with 7 accepted");
    }
    bounds
}

#[test]
fn a_minority_creeping_at_the_bound_never_moves_it_past_k_times_the_honest_median() {
    // 3 of 7 per buffer: 24 of the window's 56 entries, at most floor(56 / 2) = 28. The bound
    // is the floor for the first 8 versions (the window fills), then 5 x 200 for good: the
    // lower median sorted[27] is always an honest 200 (32 of them), whatever the coalition
    // submits.
    let bounds = creep(3, 40);
    assert!(bounds[..8].iter().all(|&b| b == 200), "{bounds:?}");
    assert!(bounds[8..].iter().all(|&b| b == 1000), "{bounds:?}");
}

#[test]
fn a_majority_of_the_window_grows_the_bound_by_k_per_window_and_stops_at_the_cap() {
    // 4 of 7 per buffer: 32 of 56 entries. Versions 8..=15: the median stays an honest 200
    // while the window still holds the 200s of the first 8 buffers (24 honest + 4 per early
    // buffer >= 28); at 16 it holds only the coalition's 1000s above 24 honest entries:
    // 5 x 1000; at 24, 5 x 5000 = 25,000, clamped to the cap of 20,000, where it stays.
    let bounds = creep(4, 40);
    let expect = |v: usize| match v {
        0..=7 => 200,
        8..=15 => 1000,
        16..=23 => 5000,
        _ => 20_000,
    };
    for (v, &b) in bounds.iter().enumerate() {
        assert_eq!(b, expect(v), "version {v}: {bounds:?}");
    }
}

#[test]
fn deflation_cannot_push_the_bound_below_the_floor() {
    // Four of seven submit copies of their base (distance 0) every version: the median falls
    // to 0, and the bound stays at the floor, where the honest 200s are still accepted.
    let p = params(40, 7, Some(rule(5_000_000, 1, 10_000)));
    let mut s = ContractState::genesis(&p);
    for v in 0..5u32 {
        for robot in 0..4 {
            assert!(submit(&mut s, &p, robot, 0).is_accepted());
        }
        for i in 0..3 {
            assert!(submit(&mut s, &p, 4 + 3 * v + i, 200).is_accepted());
        }
        assert_eq!(s.outlier_bound_units(&p), 200);
    }
    assert_eq!(s.round, 5);
}

#[test]
fn the_window_enters_the_digest_only_when_it_holds_distances() {
    let relative = params(10, 2, Some(rule(1_500_000, 2, 400)));
    let absolute = params(10, 2, None);
    let (mut r, mut a) = (
        ContractState::genesis(&relative),
        ContractState::genesis(&absolute),
    );
    assert_eq!(r.digest(), a.digest(), "an empty window is not hashed");
    for robot in 0..2 {
        submit(&mut r, &relative, robot, 150);
        submit(&mut a, &absolute, robot, 150);
    }
    assert_eq!(r.weights, a.weights);
    assert_ne!(
        r.digest(),
        a.digest(),
        "a kept distance is part of the state"
    );
    let encoded = rmp_serde::to_vec(&a).unwrap();
    let back: ContractState = rmp_serde::from_slice(&encoded).unwrap();
    assert_eq!(back.digest(), a.digest());
    let encoded = rmp_serde::to_vec(&r).unwrap();
    let back: ContractState = rmp_serde::from_slice(&encoded).unwrap();
    assert_eq!(back.digest(), r.digest());
}

#[test]
fn parameters_check_the_factor_window_and_cap() {
    assert!(rule(1, 1, 100).check(100).is_ok());
    assert!(rule(0, 1, 100).check(100).unwrap_err().contains("factor"));
    assert!(rule(1, 0, 100).check(100).unwrap_err().contains("window"));
    assert!(rule(1, 1025, 100)
        .check(100)
        .unwrap_err()
        .contains("window"));
    assert!(rule(1, 1, 99).check(100).unwrap_err().contains("cap"));
    // The contract refuses the rule without the buffered protocol.
    let mut p = params(10, 2, Some(rule(1, 1, 100)));
    assert!(p.check().is_ok());
    p.buffered = None;
    assert!(p.check().unwrap_err().contains("relative outlier rule"));
}

fn resolve(sets: &[&str]) -> Result<crate::config::Config, String> {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    crate::config::Config::resolve(None, None, &sets).map_err(|e| e.to_string())
}

#[test]
fn absurd_relative_settings_are_refused_naming_the_key() {
    let (b, r) = (
        "contract.protocol=buffered",
        "contract.outlier_rule=relative",
    );
    for bad in ["0", "-1", "1001", "nan"] {
        let err = resolve(&[b, r, &format!("contract.outlier_factor={bad}")]).unwrap_err();
        assert!(err.contains("contract.outlier_factor"), "{err}");
    }
    for bad in ["0", "1025"] {
        let err = resolve(&[b, r, &format!("contract.outlier_window={bad}")]).unwrap_err();
        assert!(err.contains("contract.outlier_window"), "{err}");
    }
    // Range checks run under the absolute rule too, so a typo waits for nobody.
    let err = resolve(&["contract.outlier_cap=-1"]).unwrap_err();
    assert!(err.contains("contract.outlier_cap"), "{err}");
    // The cap must not be below the floor, only when the relative rule uses both.
    let err = resolve(&[b, r, "contract.outlier_cap=0.04"]).unwrap_err();
    assert!(
        err.contains("contract.outlier_cap") && err.contains("outlier_threshold = 0.05"),
        "{err}"
    );
    assert!(resolve(&[b, "contract.outlier_threshold=0.4"]).is_ok());
    // Only under the buffered protocol and the paper's rule.
    let err = resolve(&[r]).unwrap_err();
    assert!(
        err.contains("contract.outlier_rule") && err.contains("contract.protocol = buffered"),
        "{err}"
    );
    let err = resolve(&[b, r, "contract.rule=median"]).unwrap_err();
    assert!(
        err.contains("contract.outlier_rule") && err.contains("contract.rule = median"),
        "{err}"
    );
    let err = resolve(&[b, r, "contract.security=false"]).unwrap_err();
    assert!(err.contains("contract.outlier_rule"), "{err}");
    let err = resolve(&[b, "contract.outlier_rule=relatve"]).unwrap_err();
    assert!(err.contains("`relative`"), "{err}");
}

#[test]
fn the_engine_refuses_the_relative_rule_naming_it() {
    // With or without the `evm` feature: the rule's own check runs first.
    let err = resolve(&[
        "contract.protocol=buffered",
        "contract.outlier_rule=relative",
        "contract.engine=evm",
    ])
    .unwrap_err();
    assert!(
        err.contains("contract.outlier_rule") && err.contains("contract.engine = native"),
        "{err}"
    );
}

#[test]
fn the_keys_reach_the_genesis_parameters_only_when_relative() {
    let b = "contract.protocol=buffered";
    let absolute = resolve(&[b, "contract.outlier_factor=3"]).unwrap();
    let p = ContractParams::from_config(&absolute, vec![0i64; 4].into());
    assert_eq!(p.outlier, None);
    let text = absolute.to_toml();
    assert!(!text.contains("outlier_rule"), "{text}");
    assert!(text.contains("outlier_factor = 3.0"), "{text}");
    let relative = resolve(&[
        b,
        "contract.outlier_rule=relative",
        "contract.outlier_factor=2.5",
        "contract.outlier_window=3",
        "contract.outlier_cap=0.125",
    ])
    .unwrap();
    assert!(relative.to_toml().contains("outlier_rule = \"relative\""));
    let p = ContractParams::from_config(&relative, vec![0i64; 4].into());
    assert_eq!(p.outlier, Some(rule(2_500_000, 3, 125_000_000)));
    assert!(p.check().is_ok());
    // The parameters' encoding (the genesis commitment) grows by the rule, and only then.
    let mut without = p.clone();
    without.outlier = None;
    let (with, without) = (
        rmp_serde::to_vec(&p).unwrap(),
        rmp_serde::to_vec(&without).unwrap(),
    );
    assert!(
        with.len() > without.len(),
        "{} vs {}",
        with.len(),
        without.len()
    );
}

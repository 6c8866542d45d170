//! Hand-computed rounds of the contract. A 4-weight model keeps the numbers readable; tokens
//! are 10^9 units as in the paper's configuration.

use std::sync::Arc;

use super::payout::{div_round_half_away, fedavg, payouts, rank};
use super::*;
use crate::config::{FedAvgRounding, MedianRule, PayoutRounding, RankTies};
use crate::contract::test_support::{STAKE, TOKEN};

const ROBOTS: u32 = 10;

/// 10 robots with 21 tokens, stake 5, quorum 7, k = [1, 1, 1, 1, 1, -1, -1], threshold 0.05
/// (50_000_000 units, so a 4-weight model may be at most 200_000_000 units away), genesis 0.
fn params(security: bool) -> ContractParams {
    ContractParams {
        security,
        ..super::test_support::params(ROBOTS, vec![1, 1, 1, 1, 1, -1, -1], 4)
    }
}

fn model(w: [i64; 4]) -> Arc<[i64]> {
    w.to_vec().into()
}

fn submit(w: [i64; 4], samples: u64) -> Call {
    Call::SubmitModel {
        weights: model(w),
        samples,
    }
}

/// Executes `call` and checks its outcome, token conservation and, for every failure, that
/// nothing at all changed.
fn check(
    state: &mut ContractState,
    p: &ContractParams,
    sender: RobotId,
    value: u64,
    call: Call,
    expect: Outcome,
) {
    let before = state.clone();
    let got = state.execute(p, sender, value, &call);
    assert_eq!(got, expect, "call from {sender}");
    assert_eq!(
        state.total_units(),
        u128::from(ROBOTS) * 21 * u128::from(TOKEN),
        "conservation"
    );
    let unchanged = matches!(
        got,
        Outcome::Duplicate
            | Outcome::InsufficientStake
            | Outcome::InsufficientFunds
            | Outcome::Malformed(_)
    );
    if unchanged {
        assert_eq!(*state, before, "a failed call changed the state");
        assert_eq!(state.digest(), before.digest());
    } else if got != Outcome::Transferred {
        assert_ne!(
            state.digest(),
            before.digest(),
            "a state change must show in the digest"
        );
    }
}

fn accepted(round: u64, distance_units: u64) -> Outcome {
    Outcome::Accepted {
        round,
        distance_units,
    }
}

fn outlier(round: u64, distance_units: u64) -> Outcome {
    Outcome::Outlier {
        round,
        distance_units,
    }
}

fn pay(robot: RobotId, rank: u32, reward_weight: i64, units: u64) -> Payout {
    Payout {
        robot,
        rank,
        reward_weight,
        units,
    }
}

/// Round 0: seven accepted models and two outliers, interleaved.
///
/// Distances (d = w_0, genesis 0), in millions of units, and samples:
///   r0 10 (100), r1 20 (200), r2 30 (100), r3 40 (300), r4 50 (100), r5 150 (200), r6 190 (100);
///   outliers r7 200_000_001 units (one above the threshold), r8 3 * (2^47 - 1).
/// Sorted d: 10 20 30 40 50 150 190, median 40. |d - 40|: r0 30, r1 20, r2 10, r3 0, r4 10,
/// r5 110, r6 150. Ranking (r2 before r4 on their tie, by submission order):
///   r3, r2, r4, r1, r0 | r5, r6.
/// Pool P = 9 stakes = 45e9. floor(P / 7) = 6_428_571_428.
/// Rewarded (sum_R s = 300 + 100 + 100 + 200 + 100 = 800), bonus 5e9 * s / 800 = 6_250_000 s:
///   r3 1_875_000_000, r2 625_000_000, r4 625_000_000, r1 1_250_000_000, r0 625_000_000.
/// Penalised (sum_P s = 300): r5 ceil(5e9 * 200 / 300) = 3_333_333_334,
///   r6 ceil(5e9 * 100 / 300) = 1_666_666_667.
/// Paid 7 * 6_428_571_428 + 5e9 - 5_000_000_001 = 44_999_999_995; carried 5 units.
/// FedAvg (sum of accepted samples 1100; r0 sends [10e6 - 1, 0, 0, -1], r2 sends [0, 30e6, 0, 0]):
///   w_0 = (100 (10e6 - 1) + 200 * 20e6 + 300 * 40e6 + 100 * 50e6 + 200 * 150e6 + 100 * 190e6) / 1100
///       = (71_000e6 - 100) / 1100 = 64_545_454.45 -> 64_545_454;
///   w_1 = 100 * 30e6 / 1100 = 2_727_272.73 -> 2_727_273; w_2 = 0; w_3 = -100 / 1100 -> 0.
fn round_zero(state: &mut ContractState, p: &ContractParams) {
    const M: i64 = 1_000_000;
    check(
        state,
        p,
        0,
        STAKE,
        submit([10 * M - 1, 0, 0, -1], 100),
        accepted(0, 10_000_000),
    );
    check(
        state,
        p,
        7,
        STAKE,
        submit([0, 100_000_000, 0, 100_000_001], 50),
        outlier(0, 200_000_001),
    );
    check(
        state,
        p,
        1,
        STAKE,
        submit([20 * M, 0, 0, 0], 200),
        accepted(0, 20_000_000),
    );
    check(
        state,
        p,
        2,
        STAKE,
        submit([0, 30 * M, 0, 0], 100),
        accepted(0, 30_000_000),
    );
    let extreme = (1i64 << 47) - 1;
    check(
        state,
        p,
        8,
        STAKE,
        submit([extreme, -extreme, extreme, 0], 200),
        outlier(0, 3 * extreme as u64),
    );
    check(
        state,
        p,
        3,
        STAKE,
        submit([40 * M, 0, 0, 0], 300),
        accepted(0, 40_000_000),
    );
    check(
        state,
        p,
        4,
        STAKE,
        submit([50 * M, 0, 0, 0], 100),
        accepted(0, 50_000_000),
    );
    check(
        state,
        p,
        5,
        STAKE,
        submit([150 * M, 0, 0, 0], 200),
        accepted(0, 150_000_000),
    );
    assert_eq!(state.accepted_count(), 6);
    assert_eq!(state.holdings_units, 8 * STAKE);
    let expect_payouts = vec![
        pay(3, 0, 1, 8_303_571_428),
        pay(2, 1, 1, 7_053_571_428),
        pay(4, 2, 1, 7_053_571_428),
        pay(1, 3, 1, 7_678_571_428),
        pay(0, 4, 1, 7_053_571_428),
        pay(5, 5, -1, 3_095_238_094),
        pay(6, 6, -1, 4_761_904_761),
    ];
    check(
        state,
        p,
        6,
        STAKE,
        submit([190 * M, 0, 0, 0], 100),
        Outcome::Aggregated {
            round: 0,
            distance_units: 190_000_000,
            payouts: expect_payouts.clone(),
        },
    );
    assert_eq!(state.round, 1);
    assert_eq!(&state.weights[..], &[64_545_454, 2_727_273, 0, 0]);
    assert_eq!(
        state.previous_weights.as_deref(),
        Some(&[0i64, 0, 0, 0][..])
    );
    assert_eq!(
        state.holdings_units, 5,
        "the rounding remainder stays in the contract"
    );
    let expect_balances = [
        16 * TOKEN + 7_053_571_428,
        16 * TOKEN + 7_678_571_428,
        16 * TOKEN + 7_053_571_428,
        16 * TOKEN + 8_303_571_428,
        16 * TOKEN + 7_053_571_428,
        16 * TOKEN + 3_095_238_094,
        16 * TOKEN + 4_761_904_761,
        16 * TOKEN,
        16 * TOKEN,
        21 * TOKEN,
    ];
    assert_eq!(state.balances, expect_balances);
    let last = state.last_round.as_deref().expect("a round closed");
    assert_eq!(
        (last.round, last.pool_units, last.carried_units),
        (0, 45 * TOKEN, 5)
    );
    assert_eq!(last.payouts, expect_payouts);
    let senders: Vec<RobotId> = last.submissions.iter().map(|s| s.sender).collect();
    assert_eq!(senders, [0, 7, 1, 2, 8, 3, 4, 5, 6]);
    assert!(state.submissions.is_empty(), "round state resets");
}

#[test]
fn a_round_of_seven_accepted_and_two_outliers_pays_to_the_unit() {
    let p = params(true);
    let mut state = ContractState::genesis(&p);
    round_zero(&mut state, &p);
}

/// Round 1: the 5 carried units are paid out. Robot 9 is an outlier first, then r0..r6 send the
/// shared model itself (distance 0 each, all tied: ranked in submission order), 100 samples each.
/// P = 8 stakes + 5 = 40_000_000_005 = 7 * 5_714_285_715 exactly: the carry is paid.
/// Rewarded: 5_714_285_715 + 5e9 * 100 / 500 = 6_714_285_715;
/// penalised: 5_714_285_715 - 5e9 * 100 / 200 = 3_214_285_715. Sum = P, nothing carried.
#[test]
fn the_remainder_rolls_into_the_next_pool_and_is_paid_later() {
    let p = params(true);
    let mut state = ContractState::genesis(&p);
    round_zero(&mut state, &p);
    let before = state.balances.clone();
    let shared = state.weights.clone();
    let far = [shared[0] + 200_000_001, shared[1], shared[2], shared[3]];
    check(
        &mut state,
        &p,
        9,
        STAKE,
        submit(far, 10),
        outlier(1, 200_000_001),
    );
    let same: [i64; 4] = shared[..].try_into().expect("4 weights");
    for robot in 0..6 {
        check(
            &mut state,
            &p,
            robot,
            STAKE,
            submit(same, 100),
            accepted(1, 0),
        );
    }
    let payouts: Vec<Payout> = (0..7)
        .map(|r| {
            if r < 5 {
                pay(r, r, 1, 6_714_285_715)
            } else {
                pay(r, r, -1, 3_214_285_715)
            }
        })
        .collect();
    check(
        &mut state,
        &p,
        6,
        STAKE,
        submit(same, 100),
        Outcome::Aggregated {
            round: 1,
            distance_units: 0,
            payouts: payouts.clone(),
        },
    );
    assert_eq!(state.holdings_units, 0);
    assert_eq!(state.round, 2);
    assert_eq!(
        state.weights, shared,
        "the mean of identical models is that model"
    );
    assert_eq!(state.previous_weights.as_deref(), Some(&shared[..]));
    for (robot, (after, before)) in state.balances.iter().zip(&before).enumerate() {
        let expect = match robot {
            0..=4 => before - STAKE + 6_714_285_715,
            5 | 6 => before - STAKE + 3_214_285_715,
            9 => before - STAKE,
            _ => *before,
        };
        assert_eq!(*after, expect, "robot {robot}");
    }
}

#[test]
fn every_rejection_reason_leaves_the_state_unchanged() {
    let p = params(true);
    let mut s = ContractState::genesis(&p);
    let ok = [1, 2, 3, 4];
    let malformed = |reason: &str| Outcome::Malformed(reason.to_string());
    check(
        &mut s,
        &p,
        0,
        STAKE,
        submit(ok, 0),
        malformed("samples must be at least 1, got 0"),
    );
    check(
        &mut s,
        &p,
        0,
        STAKE,
        submit(ok, 1 << 32),
        malformed("samples 4294967296 exceed the limit 4294967295"),
    );
    let short = Call::SubmitModel {
        weights: vec![1, 2, 3].into(),
        samples: 10,
    };
    check(
        &mut s,
        &p,
        0,
        STAKE,
        short,
        malformed("model has 3 weights, the shared model has 4"),
    );
    check(
        &mut s,
        &p,
        0,
        STAKE,
        submit([0, -(1 << 47), 0, 0], 10),
        malformed("weight 1 = -140737488355328 is outside int48 (|w| < 2^47)"),
    );
    check(
        &mut s,
        &p,
        0,
        STAKE,
        submit([0, 0, i64::MIN, 0], 10),
        malformed("weight 2 = -9223372036854775808 is outside int48 (|w| < 2^47)"),
    );
    check(
        &mut s,
        &p,
        10,
        STAKE,
        submit(ok, 10),
        malformed("submission from 10: accounts are 0..10"),
    );
    check(
        &mut s,
        &p,
        u32::MAX,
        STAKE,
        submit(ok, 10),
        malformed("submission from 4294967295: accounts are 0..10"),
    );
    check(
        &mut s,
        &p,
        0,
        STAKE - 1,
        submit(ok, 10),
        Outcome::InsufficientStake,
    );
    check(&mut s, &p, 0, 0, submit(ok, 10), Outcome::InsufficientStake);
    check(
        &mut s,
        &p,
        0,
        STAKE + 1,
        submit(ok, 10),
        malformed("value 5000000001 exceeds the stake of 5000000000 units; send exactly the stake"),
    );
    // Robot 1 gives away all but 5 tokens - 1 unit: its balance is then below the stake.
    check(
        &mut s,
        &p,
        1,
        0,
        Call::Transfer {
            to: 2,
            amount_units: 16 * TOKEN + 1,
        },
        Outcome::Transferred,
    );
    check(
        &mut s,
        &p,
        1,
        STAKE,
        submit(ok, 10),
        Outcome::InsufficientStake,
    );
    // A duplicate after an accepted model and after an outlier.
    check(&mut s, &p, 0, STAKE, submit(ok, 10), accepted(0, 10));
    check(&mut s, &p, 0, STAKE, submit(ok, 10), Outcome::Duplicate);
    check(
        &mut s,
        &p,
        3,
        STAKE,
        submit([1 << 46, 0, 0, 0], 10),
        outlier(0, 1 << 46),
    );
    check(&mut s, &p, 3, STAKE, submit(ok, 10), Outcome::Duplicate);
    assert_eq!(s.holdings_units, 2 * STAKE);
    assert_eq!(s.accepted_count(), 1);
}

#[test]
fn transfers_move_tokens_between_accounts() {
    let p = params(true);
    let mut s = ContractState::genesis(&p);
    let transfer = |to, amount_units| Call::Transfer { to, amount_units };
    check(
        &mut s,
        &p,
        0,
        0,
        transfer(1, 3 * TOKEN),
        Outcome::Transferred,
    );
    check(&mut s, &p, 0, 0, transfer(0, 7), Outcome::Transferred);
    check(
        &mut s,
        &p,
        0,
        0,
        transfer(1, 18 * TOKEN + 1),
        Outcome::InsufficientFunds,
    );
    check(
        &mut s,
        &p,
        0,
        0,
        transfer(10, 1),
        Outcome::Malformed("transfer from 0 to 10: accounts are 0..10".into()),
    );
    check(
        &mut s,
        &p,
        11,
        0,
        transfer(0, 1),
        Outcome::Malformed("transfer from 11 to 0: accounts are 0..10".into()),
    );
    check(
        &mut s,
        &p,
        0,
        1,
        transfer(1, 1),
        Outcome::Malformed("transfer carries value 1; send the amount in the call, value 0".into()),
    );
    check(
        &mut s,
        &p,
        1,
        0,
        transfer(2, 24 * TOKEN),
        Outcome::Transferred,
    );
    assert_eq!(&s.balances[..3], &[18 * TOKEN, 0, 45 * TOKEN]);
}

/// Security off: the value is ignored, no tokens move, far models are accepted, and the seventh
/// aggregates with no payouts. FedAvg of w_0 = 1e9 * k for k = 1..7 with samples k:
/// sum k^2 / sum k = 140 / 28 = 5 -> 5e9.
#[test]
fn security_off_accepts_every_valid_model_and_moves_no_tokens() {
    let p = params(false);
    let mut s = ContractState::genesis(&p);
    for k in 1..7u32 {
        let d = i64::from(k) * 1_000_000_000;
        check(
            &mut s,
            &p,
            k - 1,
            STAKE,
            submit([d, 0, 0, 0], u64::from(k)),
            accepted(0, d as u64),
        );
    }
    check(&mut s, &p, 0, STAKE, submit([0; 4], 1), Outcome::Duplicate);
    check(
        &mut s,
        &p,
        7,
        0,
        submit([0; 4], 0),
        Outcome::Malformed("samples must be at least 1, got 0".into()),
    );
    let aggregated = Outcome::Aggregated {
        round: 0,
        distance_units: 7_000_000_000,
        payouts: vec![],
    };
    check(
        &mut s,
        &p,
        6,
        u64::MAX,
        submit([7_000_000_000, 0, 0, 0], 7),
        aggregated,
    );
    assert_eq!(&s.weights[..], &[5_000_000_000, 0, 0, 0]);
    assert_eq!(s.balances, vec![21 * TOKEN; ROBOTS as usize]);
    assert_eq!(s.holdings_units, 0);
    assert_eq!(s.get_model().1, 1);
}

/// A quorum of one with no penalised rank: the single model gets the whole pool back.
#[test]
fn a_quorum_of_one_returns_the_pool() {
    let p = ContractParams {
        quorum: 1,
        reward_weights: vec![1],
        ..params(true)
    };
    let mut s = ContractState::genesis(&p);
    check(
        &mut s,
        &p,
        4,
        STAKE,
        submit([1 << 40, 0, 0, 0], 9),
        outlier(0, 1 << 40),
    );
    let expect = Outcome::Aggregated {
        round: 0,
        distance_units: 3,
        payouts: vec![pay(2, 0, 1, 2 * STAKE)],
    };
    check(&mut s, &p, 2, STAKE, submit([1, 1, 1, 0], 9), expect);
    assert_eq!(s.balances[2], 26 * TOKEN);
    assert_eq!(s.holdings_units, 0);
}

#[test]
fn ranking_puts_the_median_first_and_breaks_ties_by_submission_order() {
    fn check_rank(distances: &[u64], expect: &[usize]) {
        assert_eq!(
            rank(distances, MedianRule::Lower, RankTies::Stable),
            expect,
            "distances {distances:?}"
        );
    }
    check_rank(&[10, 20, 30, 40, 50, 150, 190], &[3, 2, 4, 1, 0, 5, 6]);
    check_rank(&[7, 7, 7], &[0, 1, 2]);
    check_rank(&[5, 1, 9], &[0, 1, 2]);
    // Even count: the lower middle (20) is the median; 10 and 30 tie and keep order.
    check_rank(&[30, 10, 20, 40], &[2, 0, 1, 3]);
    check_rank(&[u64::MAX, 0, 1], &[2, 1, 0]);
}

#[test]
fn payouts_follow_the_paper_to_the_unit() {
    fn check_pay(pool: u64, samples: &[u64], k: &[i64], expect: &[u64]) {
        assert_eq!(
            payouts(pool, STAKE, samples, k, PayoutRounding::Exact),
            expect,
            "pool {pool} samples {samples:?}"
        );
    }
    let k = [1, 1, 1, 1, 1, -1, -1];
    // No rejections, equal samples: (1 + 1/5) * 5 = 6 and (1 - 1/2) * 5 = 2.5 tokens.
    check_pay(
        35 * TOKEN,
        &[1; 7],
        &k,
        &[
            6 * TOKEN,
            6 * TOKEN,
            6 * TOKEN,
            6 * TOKEN,
            6 * TOKEN,
            2_500_000_000,
            2_500_000_000,
        ],
    );
    // Rewarded samples 1, 2 of sum 3 among R: floor(5e9 / 3) = 1_666_666_666, floor(10e9 / 3) =
    // 3_333_333_333; penalised 1 of 3: ceil(5e9 / 3) = 1_666_666_667, 2 of 3: 3_333_333_334.
    check_pay(
        20 * TOKEN,
        &[1, 2, 1, 2],
        &[1, 1, -1, -1],
        &[6_666_666_666, 8_333_333_333, 3_333_333_333, 1_666_666_666],
    );
    // Security off has no payouts; a pool of one stake with a single rewarded rank returns it.
    check_pay(STAKE, &[3], &[1], &[STAKE]);
}

#[test]
fn fedavg_rounds_to_nearest_with_ties_away_from_zero() {
    fn check_avg(models: &[(&[i64], u64)], expect: &[i64]) {
        assert_eq!(fedavg(models, FedAvgRounding::Nearest), expect);
    }
    check_avg(&[(&[1, -1, 3], 1), (&[0, 0, 0], 1)], &[1, -1, 2]); // 0.5, -0.5, 1.5
    check_avg(&[(&[1, 2, -2], 1), (&[0, 0, 0], 2)], &[0, 1, -1]); // 1/3, 2/3, -2/3
    let big = (1i64 << 47) - 1;
    check_avg(
        &[(&[big, -big], u64::from(u32::MAX)), (&[big, -big], 1)],
        &[big, -big],
    );
    assert_eq!(div_round_half_away(-7, 2), -4);
    assert_eq!(div_round_half_away(7, 2), 4);
    assert_eq!(div_round_half_away(-5, 3), -2);
}

#[test]
fn cloning_shares_the_models_and_the_digest_tracks_them() {
    let p = params(true);
    let mut s = ContractState::genesis(&p);
    check(
        &mut s,
        &p,
        0,
        STAKE,
        submit([1, 2, 3, 4], 10),
        accepted(0, 10),
    );
    let copy = s.clone();
    assert!(Arc::ptr_eq(&copy.weights, &s.weights));
    assert!(Arc::ptr_eq(
        &copy.submissions[0].weights,
        &s.submissions[0].weights
    ));
    assert_eq!(copy.digest(), s.digest());
    assert_eq!(s.weights_digest, model_digest(&s.weights));
    let q = ContractParams {
        quorum: 1,
        reward_weights: vec![1],
        ..params(true)
    };
    let mut r = ContractState::genesis(&q);
    check(
        &mut r,
        &q,
        0,
        STAKE,
        submit([1, 2, 3, 4], 10),
        Outcome::Aggregated {
            round: 0,
            distance_units: 10,
            payouts: vec![pay(0, 0, 1, STAKE)],
        },
    );
    assert_eq!(r.weights_digest, model_digest(&[1, 2, 3, 4]));
    assert_eq!(r.previous_digest, model_digest(&[0, 0, 0, 0]));
    let mut other = ContractState::genesis(&p);
    check(
        &mut other,
        &p,
        0,
        STAKE,
        submit([1, 2, 3, 5], 10),
        accepted(0, 11),
    );
    assert_ne!(
        other.digest(),
        s.digest(),
        "pending models are part of the state"
    );
}

/// A model far from the shared one (`2^40` units per weight).
const FAR: i64 = 1 << 40;

/// Six models near 10 and one far away (robot 2): the median rule tests' round.
const MEDIAN_ROUND: [[i64; 4]; 7] = [
    [10, 10, 10, 10],
    [11, 9, 10, 10],
    [FAR, FAR, FAR, FAR],
    [9, 11, 10, 10],
    [10, 10, 12, 8],
    [10, 10, 8, 12],
    [12, 8, 10, 10],
];

/// A robust rule's round: every valid model is accepted (no threshold), the rule decides the
/// model and whom it used, the used share the pool equally, the others lose their stakes.
#[test]
fn median_rule_pays_the_models_it_used_and_keeps_the_others_stakes() {
    let p = ContractParams {
        robust: Some(RobustRule {
            rule: Rule::Median,
            assumed_f: 2,
            threshold_gate: false,
        }),
        ..params(true)
    };
    let mut s = ContractState::genesis(&p);
    // The far model claims a huge sample count: under paper it would be an outlier; here it
    // is accepted, outvoted by the median and not paid.
    let mut last = None;
    for (robot, w) in MEDIAN_ROUND.iter().enumerate() {
        let samples = if robot == 2 { u64::from(u32::MAX) } else { 10 };
        let out = s.execute(&p, robot as RobotId, STAKE, &submit(*w, samples));
        assert!(out.is_accepted(), "{out:?}");
        last = Some(out);
    }
    let Some(Outcome::Aggregated { payouts, .. }) = last else {
        panic!("the seventh model aggregates: {last:?}");
    };
    // Columns sorted: (8 or 9 ..) -> median 10 in every coordinate.
    assert_eq!(&s.weights[..], &[10, 10, 10, 10]);
    // q - f = 5 used: L1 to the median: 0, 2, huge, 2, 4, 4, 4 -> robots 0, 1, 3, 4, 5.
    let paid: Vec<RobotId> = payouts.iter().map(|p| p.robot).collect();
    assert_eq!(paid, vec![0, 1, 3, 4, 5]);
    // Pool 35 tokens / 5 = 7 tokens each; robots 2 and 6 lose their 5.
    assert!(payouts.iter().all(|p| p.units == 7 * TOKEN));
    assert_eq!(s.balances[0], 23 * TOKEN);
    assert_eq!(s.balances[2], 16 * TOKEN);
    assert_eq!(s.balances[6], 16 * TOKEN);
    assert_eq!(s.holdings_units, 0);
    assert_eq!(s.total_units(), p.total_units());
}

/// The same round behind `contract.threshold_gate`: the far model is refused as it arrives
/// (an outlier, its stake kept, as under paper), the round waits for a seventh model within
/// the threshold, and the median of the seven accepted models pays the five it used.
#[test]
fn the_threshold_gate_refuses_the_far_model_before_the_median_sees_it() {
    let p = ContractParams {
        robust: Some(RobustRule {
            rule: Rule::Median,
            assumed_f: 2,
            threshold_gate: true,
        }),
        ..params(true)
    };
    assert!(p.threshold_applies());
    let mut s = ContractState::genesis(&p);
    // Threshold 50_000_000 units per weight: 200_000_000 over the 4 weights, from genesis 0.
    let at_bound = [50_000_000i64; 4];
    let models: Vec<[i64; 4]> = MEDIAN_ROUND.iter().copied().chain([at_bound]).collect();
    let mut outcomes = Vec::new();
    for (robot, w) in models.iter().enumerate() {
        let samples = if robot == 2 { u64::from(u32::MAX) } else { 10 };
        outcomes.push(s.execute(&p, robot as RobotId, STAKE, &submit(*w, samples)));
    }
    assert_eq!(
        outcomes[2],
        Outcome::Outlier {
            round: 0,
            distance_units: 4 * (FAR as u64)
        }
    );
    assert_eq!(s.balances[2], 16 * TOKEN, "the outlier's stake is kept");
    assert!(outcomes[6].is_accepted() && !matches!(outcomes[6], Outcome::Aggregated { .. }));
    let Outcome::Aggregated { payouts, .. } = &outcomes[7] else {
        panic!("the model at the bound is accepted and closes the round: {outcomes:?}");
    };
    // Per coordinate, sorted: (8 or 9, 10.., 12, 5e7) -> median 10.
    assert_eq!(&s.weights[..], &[10, 10, 10, 10]);
    // L1 to the median: 0, 2, -, 2, 4, 4, 4, ~2e8 -> q - f = 5 used: robots 0, 1, 3, 4, 5.
    let paid: Vec<RobotId> = payouts.iter().map(|p| p.robot).collect();
    assert_eq!(paid, vec![0, 1, 3, 4, 5]);
    // The pool holds the round's 7 stakes and the outlier's: 40 tokens, 8 each.
    assert!(payouts.iter().all(|p| p.units == 8 * TOKEN), "{payouts:?}");
    assert_eq!(s.holdings_units, 0);
    assert_eq!(s.total_units(), p.total_units());

    // Without the gate the same far model is accepted (the median outvotes it instead).
    let open = ContractParams {
        robust: Some(RobustRule {
            threshold_gate: false,
            ..p.robust.expect("a robust rule")
        }),
        ..p.clone()
    };
    assert!(!open.threshold_applies());
    let mut t = ContractState::genesis(&open);
    t.execute(&open, 0, STAKE, &submit(models[0], 10));
    let out = t.execute(&open, 2, STAKE, &submit(models[2], 10));
    assert!(out.is_accepted(), "{out:?}");
}

#[test]
fn robust_rules_need_their_quorum() {
    let p = ContractParams {
        robust: Some(RobustRule {
            rule: Rule::Bulyan,
            assumed_f: 2,
            threshold_gate: false,
        }),
        ..params(true)
    };
    assert!(p.check().unwrap_err().contains("quorum of at least 11"));
    assert_eq!(params(true).rule(), Rule::Paper);
    assert_eq!(params(false).rule(), Rule::Fedavg);
}

/// The parameters of paper and fedavg runs encode as they did before rules existed, so their
/// checkpoints' parameter digests do not move.
#[test]
fn paper_parameters_encode_without_the_rule() {
    let p = params(true);
    let q = ContractParams {
        robust: Some(RobustRule {
            rule: Rule::Krum,
            assumed_f: 1,
            threshold_gate: false,
        }),
        ..params(true)
    };
    let a = rmp_serde::to_vec(&p).unwrap();
    let b = rmp_serde::to_vec(&q).unwrap();
    assert!(b.len() > a.len());
    assert_eq!(
        &b[1..a.len()],
        &a[1..],
        "the same fields, one more at the end"
    );
    let back: ContractParams = rmp_serde::from_slice(&a).unwrap();
    assert_eq!(back, p);
    let back: ContractParams = rmp_serde::from_slice(&b).unwrap();
    assert_eq!(back, q);
}

/// `contract.threshold_gate` came after robust rules had records: off, a robust rule encodes
/// (and so hashes) as its two fields did; on, it encodes a third and reads back.
#[test]
fn a_robust_rule_without_the_gate_encodes_as_before() {
    let off = RobustRule {
        rule: Rule::Krum,
        assumed_f: 1,
        threshold_gate: false,
    };
    assert_eq!(
        rmp_serde::to_vec(&off).unwrap(),
        rmp_serde::to_vec(&(Rule::Krum, 1u32)).unwrap()
    );
    let on = RobustRule {
        threshold_gate: true,
        ..off
    };
    let bytes = rmp_serde::to_vec(&on).unwrap();
    assert_eq!(rmp_serde::from_slice::<RobustRule>(&bytes).unwrap(), on);
    let old = rmp_serde::to_vec(&(Rule::Krum, 1u32)).unwrap();
    assert_eq!(rmp_serde::from_slice::<RobustRule>(&old).unwrap(), off);
}

/// `contract.rank_order`: one model close to the shared model (robot 6 at 5e6 units, an
/// extrapolation's place) among six at 40e6..90e6, 100 samples each. Pool 7 stakes = 35e9,
/// floor(P / 7) = 5e9; the five rewarded get 5e9 + 5e9 * 100 / 500 = 6e9, the two penalised
/// 5e9 - ceil(5e9 * 100 / 200) = 2.5e9. Around the median (60e6; keys 20, 10, 0, 10, 20, 30,
/// 55 in 10^6) the lone model ranks last and is penalised; nearest first, it ranks first.
#[test]
fn rank_order_nearest_pays_the_lone_near_model_that_the_median_order_penalises() {
    const M: i64 = 1_000_000;
    let distances = [40, 50, 60, 70, 80, 90, 5];
    let run = |order: crate::config::RankOrder| {
        let mut p = params(true);
        p.options.rank_order = order;
        let mut state = ContractState::genesis(&p);
        for (robot, &d) in distances.iter().enumerate().take(6) {
            check(
                &mut state,
                &p,
                robot as RobotId,
                STAKE,
                submit([d * M, 0, 0, 0], 100),
                accepted(0, d as u64 * M as u64),
            );
        }
        let outcome = state.execute(&p, 6, STAKE, &submit([5 * M, 0, 0, 0], 100));
        let Outcome::Aggregated { payouts, .. } = outcome else {
            panic!("the seventh model closes the round: {outcome:?}");
        };
        assert_eq!(state.holdings_units, 0, "the pool is paid exactly");
        payouts
            .iter()
            .map(|p| (p.robot, p.units))
            .collect::<Vec<_>>()
    };
    let (win, lose) = (6 * TOKEN, 2 * TOKEN + TOKEN / 2);
    assert_eq!(
        run(crate::config::RankOrder::Median),
        [
            (2, win),
            (1, win),
            (3, win),
            (0, win),
            (4, win),
            (5, lose),
            (6, lose)
        ]
    );
    assert_eq!(
        run(crate::config::RankOrder::Nearest),
        [
            (6, win),
            (0, win),
            (1, win),
            (2, win),
            (3, win),
            (4, lose),
            (5, lose)
        ]
    );
}

//! Property tests of every aggregation rule inside the contract, over random hostile
//! transaction sequences (wrong lengths, int48-edge and out-of-range weights, zero and huge
//! sample claims, wrong stakes, unknown senders, transfers): tokens conserved after every call,
//! no panic (so no balance below zero), payouts only to the round's accepted senders and never
//! more than the pool, and every new shared model inside the range of the round's models and
//! the model it replaced.

use std::sync::Arc;

use proptest::prelude::*;
use swarmfl_core::config::Rule;
use swarmfl_core::contract::{
    Call, ContractParams, ContractState, Outcome, RobustRule, MAX_WEIGHT_MAGNITUDE,
};
use swarmfl_core::RobotId;

mod common;
use common::{base_params, robust, INT48, STAKE, TOKEN};

const ROBOTS: u32 = 9;

/// Quorum 7 with f = 1: every rule is defined (bulyan needs 4f + 3 = 7). `gate`: the paper's
/// threshold in front of a robust rule (`contract.threshold_gate`), at twice the base
/// threshold, so that the int48-edge weights are the outliers and most sequences still close
/// rounds (at the base threshold a gated rule closes 2 to 14 rounds in 20 sequences).
fn params(rule: Rule, gate: bool) -> ContractParams {
    let base = base_params(ROBOTS, vec![1, 1, 1, 1, 1, -1, -1]);
    ContractParams {
        security: rule.stakes(),
        outlier_threshold_units: if gate {
            2 * base.outlier_threshold_units
        } else {
            base.outlier_threshold_units
        },
        robust: robust(rule).map(|r| RobustRule {
            threshold_gate: gate,
            ..r
        }),
        ..base
    }
}

/// Every built-in rule, and every robust one again behind the threshold gate.
fn variants() -> Vec<(Rule, bool)> {
    let robust = Rule::ALL
        .into_iter()
        .filter(|r| !matches!(r, Rule::Fedavg | Rule::Paper));
    Rule::ALL
        .into_iter()
        .map(|r| (r, false))
        .chain(robust.map(|r| (r, true)))
        .collect()
}

#[derive(Clone, Debug)]
struct Tx {
    sender: RobotId,
    value_units: u64,
    call: Call,
}

fn weight() -> impl Strategy<Value = i64> {
    prop_oneof![
        40 => -60_000_000i64..60_000_000,
        3 => Just(INT48 - 1),
        3 => Just(-(INT48 - 1)),
        1 => Just(INT48),
        1 => Just(-INT48),
        1 => any::<i64>(),
    ]
}

fn tx() -> impl Strategy<Value = Tx> {
    let sender = prop_oneof![12 => 0..ROBOTS, 1 => ROBOTS..ROBOTS + 3, 1 => Just(u32::MAX)];
    let len = prop_oneof![30 => Just(3usize), 1 => 0usize..6];
    let weights = len.prop_flat_map(|n| proptest::collection::vec(weight(), n));
    let samples = prop_oneof![
        20 => 1u64..1000,
        1 => Just(0u64),
        4 => Just(u64::from(u32::MAX)),
        1 => Just(u64::from(u32::MAX) + 1),
        1 => Just(u64::MAX),
    ];
    let value = prop_oneof![
        30 => Just(STAKE),
        1 => Just(0u64),
        1 => Just(STAKE - 1),
        1 => Just(STAKE + 1),
        1 => any::<u64>(),
    ];
    let submit = (sender.clone(), value, weights, samples).prop_map(
        |(sender, value_units, weights, samples)| Tx {
            sender,
            value_units,
            call: Call::SubmitModel {
                weights: Arc::from(weights),
                samples,
            },
        },
    );
    let transfer = (
        sender,
        0..ROBOTS + 2,
        prop_oneof![0u64..30 * TOKEN, any::<u64>()],
    )
        .prop_map(|(sender, to, amount_units)| Tx {
            sender,
            value_units: 0,
            call: Call::Transfer { to, amount_units },
        });
    prop_oneof![8 => submit, 1 => transfer]
}

fn run((rule, gate): (Rule, bool), txs: &[Tx]) -> Result<u64, TestCaseError> {
    let p = params(rule, gate);
    prop_assert_eq!(p.threshold_applies(), rule == Rule::Paper || gate);
    let mut state = ContractState::genesis(&p);
    for (step, tx) in txs.iter().enumerate() {
        let before = state.clone();
        let outcome = state.execute(&p, tx.sender, tx.value_units, &tx.call);
        prop_assert_eq!(
            state.total_units(),
            p.total_units(),
            "{}: conservation at step {}",
            rule.name(),
            step
        );
        let staked: u64 = state.submissions.iter().map(|s| s.stake_units).sum();
        prop_assert!(
            staked <= state.holdings_units,
            "the contract holds the stakes"
        );
        if let Outcome::Aggregated { payouts, .. } = &outcome {
            let last = state.last_round.as_deref().expect("recorded");
            let accepted: Vec<RobotId> = last
                .submissions
                .iter()
                .filter(|s| s.verdict == swarmfl_core::contract::Verdict::Accepted)
                .map(|s| s.sender)
                .collect();
            prop_assert_eq!(accepted.len(), 7);
            let paid: u64 = payouts.iter().map(|p| p.units).sum();
            prop_assert!(paid <= last.pool_units);
            prop_assert_eq!(last.pool_units - paid, last.carried_units);
            let mut robots: Vec<RobotId> = payouts.iter().map(|p| p.robot).collect();
            prop_assert!(
                robots.iter().all(|r| accepted.contains(r)),
                "pays only accepted"
            );
            robots.sort_unstable();
            robots.dedup();
            prop_assert_eq!(robots.len(), payouts.len(), "pays each robot once");
            prop_assert_eq!(payouts.is_empty(), !rule.stakes());
            // Every robust rule uses at least q - f - 1, except signguard, whose filters keep
            // a set of no fixed size (at least one).
            if rule.stakes() && rule != Rule::Paper && rule != Rule::Signguard {
                prop_assert!(payouts.len() >= 7 - 2, "uses at least q - f - 1");
            }
            if rule == Rule::Signguard {
                prop_assert!(!payouts.is_empty(), "signguard uses at least one");
            }
            for i in 0..state.weights.len() {
                let column = last
                    .submissions
                    .iter()
                    .filter(|s| s.verdict == swarmfl_core::contract::Verdict::Accepted)
                    .map(|s| s.weights[i])
                    .chain(std::iter::once(before.weights[i]));
                let (lo, hi) =
                    column.fold((i64::MAX, i64::MIN), |(lo, hi), w| (lo.min(w), hi.max(w)));
                prop_assert!(
                    (lo..=hi).contains(&state.weights[i]),
                    "{}: weight {} = {} outside [{}, {}]",
                    rule.name(),
                    i,
                    state.weights[i],
                    lo,
                    hi
                );
                prop_assert!(state.weights[i].unsigned_abs() < MAX_WEIGHT_MAGNITUDE);
            }
        }
    }
    Ok(state.round)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn every_rule_conserves_tokens_under_hostile_input(
        txs in proptest::collection::vec(tx(), 1..160)
    ) {
        for variant in variants() {
            run(variant, &txs)?;
        }
    }
}

/// The generator closes rounds under every rule (so the aggregation branch is exercised).
#[test]
fn hostile_sequences_reach_aggregations_under_every_rule() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{Config, TestRng, TestRunner};

    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::deterministic_rng(Default::default()),
    );
    let strategy = proptest::collection::vec(tx(), 150..160);
    for (rule, gate) in variants() {
        let mut rounds = 0;
        let mut outliers = 0;
        for _ in 0..10 {
            let txs = strategy.new_tree(&mut runner).expect("generates").current();
            rounds += run((rule, gate), &txs).expect("the properties hold");
            outliers += count_outliers(&params(rule, gate), &txs);
        }
        assert!(
            rounds >= 3,
            "{} (gate {gate}): {rounds} aggregations",
            rule.name()
        );
        // The threshold refuses some models where it applies, and only there.
        let gated = rule == Rule::Paper || gate;
        assert_eq!(
            outliers > 0,
            gated,
            "{} (gate {gate}): {outliers} outliers",
            rule.name()
        );
    }
}

/// Submissions the contract refuses as outliers on `txs`.
fn count_outliers(p: &ContractParams, txs: &[Tx]) -> usize {
    let mut state = ContractState::genesis(p);
    txs.iter()
        .filter(|tx| {
            matches!(
                state.execute(p, tx.sender, tx.value_units, &tx.call),
                Outcome::Outlier { .. }
            )
        })
        .count()
}

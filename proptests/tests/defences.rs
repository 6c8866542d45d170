//! Property tests of the defences of the reward rule (`contract.defence`, issue 16). The
//! defences take no scores or attestations from robots: the contract computes every score from
//! the models, so the hostile input is the models and the transactions themselves (wrong
//! lengths, int48-edge and out-of-range weights, identical and duplicated models, zero and
//! huge sample claims, wrong stakes, unknown senders). Properties: tokens conserved after every
//! call under each defence and rule, payouts only to the used submissions, never more than the
//! pool, and never less than the flat refund; the score and payout functions on arbitrary
//! (also out-of-range) scores and models: bounded, order-free, duplicates treated alike.

use std::sync::Arc;

use proptest::prelude::*;
use swarmfl_core::config::{Defence, Rule};
use swarmfl_core::contract::defences::{self, DefenceParams};
use swarmfl_core::contract::{Call, ContractParams, ContractState, Outcome, Verdict};
use swarmfl_core::RobotId;

mod common;
use common::{base_params, robust, INT48, STAKE, TOKEN};

const ROBOTS: u32 = 9;
const RULES: [Rule; 4] = [Rule::Paper, Rule::Krum, Rule::Median, Rule::MultiKrum];

fn params(rule: Rule, defence: Defence, refund_percent: u32) -> ContractParams {
    ContractParams {
        genesis_weights: vec![0i64, 1_000_000, -1_000_000, 7].into(),
        robust: robust(rule),
        defence: Some(DefenceParams {
            defence,
            refund_percent,
        }),
        ..base_params(ROBOTS, vec![1, 1, 1, 1, 1, -1, -1])
    }
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
        4 => Just(0i64),
        1 => Just(INT48),
        1 => any::<i64>(),
    ]
}

/// Models of the right length, and often the same few models again (duplicates, copies).
fn weights() -> impl Strategy<Value = Vec<i64>> {
    prop_oneof![
        30 => proptest::collection::vec(weight(), 4),
        8 => Just(vec![0i64, 1_000_000, -1_000_000, 7]),
        8 => Just(vec![10_000_000i64, 11_000_000, -9_000_000, 10_000_007]),
        1 => proptest::collection::vec(weight(), 0..6),
    ]
}

fn tx() -> impl Strategy<Value = Tx> {
    let sender = prop_oneof![12 => 0..ROBOTS, 1 => ROBOTS..ROBOTS + 3];
    let samples = prop_oneof![
        20 => 1u64..1000,
        1 => Just(0u64),
        3 => Just(u64::from(u32::MAX)),
        1 => Just(u64::MAX),
    ];
    let value = prop_oneof![30 => Just(STAKE), 1 => Just(0u64), 1 => Just(STAKE + 1)];
    let submit = (sender.clone(), value, weights(), samples).prop_map(
        |(sender, value_units, weights, samples)| Tx {
            sender,
            value_units,
            call: Call::SubmitModel {
                weights: Arc::from(weights),
                samples,
            },
        },
    );
    let transfer =
        (sender, 0..ROBOTS, 0u64..30 * TOKEN).prop_map(|(sender, to, amount_units)| Tx {
            sender,
            value_units: 0,
            call: Call::Transfer { to, amount_units },
        });
    prop_oneof![10 => submit, 1 => transfer]
}

fn run(rule: Rule, defence: Defence, refund: u32, txs: &[Tx]) -> Result<u64, TestCaseError> {
    let p = params(rule, defence, refund);
    let mut state = ContractState::genesis(&p);
    for (step, tx) in txs.iter().enumerate() {
        let outcome = state.execute(&p, tx.sender, tx.value_units, &tx.call);
        prop_assert_eq!(
            state.total_units(),
            p.total_units(),
            "{} {}: conservation at step {}",
            rule.name(),
            defence.name(),
            step
        );
        if let Outcome::Aggregated { payouts, .. } = &outcome {
            let last = state.last_round.as_deref().expect("recorded");
            let accepted: Vec<RobotId> = last
                .submissions
                .iter()
                .filter(|s| s.verdict == Verdict::Accepted)
                .map(|s| s.sender)
                .collect();
            let paid: u64 = payouts.iter().map(|p| p.units).sum();
            prop_assert!(paid <= last.pool_units, "within the pool");
            prop_assert_eq!(last.pool_units - paid, last.carried_units);
            prop_assert!(payouts.iter().all(|p| accepted.contains(&p.robot)));
            let base = last.pool_units / 100 * u64::from(refund) / payouts.len() as u64;
            for p in payouts {
                prop_assert!(
                    (-1_000_000_000..=1_000_000_000).contains(&p.reward_weight),
                    "score in range"
                );
                prop_assert!(p.units >= base, "at least the refund");
            }
        }
    }
    Ok(state.round)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn every_defence_conserves_tokens_under_hostile_input(
        txs in proptest::collection::vec(tx(), 1..140),
        refund in prop_oneof![Just(50u32), Just(0u32), Just(100u32), 0u32..=100],
    ) {
        for defence in [Defence::Agreement, Defence::Innovation] {
            for rule in RULES {
                run(rule, defence, refund, &txs)?;
            }
        }
    }

    /// Arbitrary scores, out of range and duplicated included: the payouts stay within the
    /// pool, everyone gets at least the refund, a higher score never gets less, and equal
    /// scores get equal payouts.
    #[test]
    fn payouts_are_bounded_and_monotone_in_any_scores(
        pool in prop_oneof![0u64..1_000, 0u64..(u64::MAX / 4)],
        scores in proptest::collection::vec(any::<i64>(), 1..12),
        refund in 0u32..=100,
    ) {
        let pay = defences::payouts(pool, &scores, refund);
        prop_assert_eq!(pay.len(), scores.len());
        let sum: u128 = pay.iter().map(|&x| u128::from(x)).sum();
        prop_assert!(sum <= u128::from(pool));
        let base = (u128::from(pool) * u128::from(refund) / 100 / scores.len() as u128) as u64;
        for i in 0..scores.len() {
            prop_assert!(pay[i] >= base);
            for j in 0..scores.len() {
                if scores[i].max(0) >= scores[j].max(0) {
                    prop_assert!(pay[i] >= pay[j], "monotone: {:?} -> {:?}", scores, pay);
                }
            }
        }
    }

    /// Scores of arbitrary int48 models: in range, the same for identical models, and
    /// independent of the order of the submissions.
    #[test]
    fn scores_are_bounded_order_free_and_equal_for_copies(
        models in proptest::collection::vec(proptest::collection::vec(-(INT48 - 1)..INT48, 5), 1..8),
        shared in proptest::collection::vec(-(INT48 - 1)..INT48, 5),
        previous in proptest::collection::vec(-(INT48 - 1)..INT48, 5),
        copy in any::<prop::sample::Index>(),
    ) {
        let mut models = models;
        let copied = models[copy.index(models.len())].clone();
        models.push(copied.clone());
        for defence in [Defence::Agreement, Defence::Innovation] {
            let refs: Vec<&[i64]> = models.iter().map(|m| &m[..]).collect();
            let s = defences::scores(defence, &shared, Some(&previous), &refs);
            prop_assert!(s.iter().all(|x| (-1_000_000_000..=1_000_000_000).contains(x)));
            let original = copy.index(models.len() - 1);
            prop_assert_eq!(s[original], s[models.len() - 1], "a copy scores as its source");
            let reversed: Vec<&[i64]> = refs.iter().rev().copied().collect();
            let mut r = defences::scores(defence, &shared, Some(&previous), &reversed);
            r.reverse();
            prop_assert_eq!(&r, &s, "order-free");
        }
    }
}

/// The generator closes rounds under every defence and rule (the payout branch runs).
#[test]
fn hostile_sequences_reach_aggregations_under_every_defence() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{Config, TestRng, TestRunner};

    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::deterministic_rng(Default::default()),
    );
    let strategy = proptest::collection::vec(tx(), 130..140);
    for defence in [Defence::Agreement, Defence::Innovation] {
        for rule in RULES {
            let mut rounds = 0;
            for _ in 0..8 {
                let txs = strategy.new_tree(&mut runner).expect("generates").current();
                rounds += run(rule, defence, 50, &txs).expect("the properties hold");
            }
            assert!(
                rounds >= 3,
                "{} {}: {rounds} aggregations",
                rule.name(),
                defence.name()
            );
        }
    }
}

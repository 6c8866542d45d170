//! Property tests of the contract over random transaction sequences, valid and adversarial:
//! conservation after every call, no panic (so no underflow), failed calls change nothing,
//! rejected models never reach the aggregate, aggregation exactly at quorum, at most one counted
//! submission per robot per round.

use std::sync::Arc;

use proptest::prelude::*;
use swarmfl_core::contract::{Call, ContractParams, ContractState, Outcome, Verdict};
use swarmfl_core::RobotId;

mod common;
use common::{base_params, INT48, STAKE, TOKEN};

const ROBOTS: u32 = 6;

fn params(security: bool) -> ContractParams {
    ContractParams {
        security,
        ..base_params(ROBOTS, vec![1, 1, -1])
    }
}

#[derive(Clone, Debug)]
struct Tx {
    sender: RobotId,
    value_units: u64,
    call: Call,
}

fn sender() -> impl Strategy<Value = RobotId> {
    prop_oneof![10 => 0..ROBOTS, 1 => ROBOTS..ROBOTS + 3, 1 => Just(u32::MAX)]
}

fn weight() -> impl Strategy<Value = i64> {
    prop_oneof![
        60 => -60_000_000i64..60_000_000,
        1 => Just(INT48 - 1),
        1 => Just(-(INT48 - 1)),
        1 => Just(INT48),
        1 => Just(-INT48),
        1 => any::<i64>(),
    ]
}

fn submission() -> impl Strategy<Value = Tx> {
    let len = prop_oneof![30 => Just(3usize), 1 => 0usize..6];
    let weights = len.prop_flat_map(|n| proptest::collection::vec(weight(), n));
    let samples = prop_oneof![
        30 => 1u64..1000,
        1 => Just(0u64),
        1 => Just(u64::from(u32::MAX)),
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
    (sender(), value, weights, samples).prop_map(|(sender, value_units, weights, samples)| Tx {
        sender,
        value_units,
        call: Call::SubmitModel {
            weights: Arc::from(weights),
            samples,
        },
    })
}

fn transfer() -> impl Strategy<Value = Tx> {
    let amount = prop_oneof![8 => 0u64..30 * TOKEN, 1 => any::<u64>()];
    let value = prop_oneof![8 => Just(0u64), 1 => any::<u64>()];
    (sender(), sender(), amount, value).prop_map(|(sender, to, amount_units, value_units)| Tx {
        sender,
        value_units,
        call: Call::Transfer { to, amount_units },
    })
}

fn transactions() -> impl Strategy<Value = Vec<Tx>> {
    proptest::collection::vec(prop_oneof![6 => submission(), 1 => transfer()], 1..250)
}

/// FedAvg written independently of the contract: round half away from zero via doubling.
fn expected_fedavg(models: &[(Arc<[i64]>, u64)]) -> Vec<i64> {
    let total: i128 = models.iter().map(|(_, n)| i128::from(*n)).sum();
    (0..models[0].0.len())
        .map(|i| {
            let num: i128 = models
                .iter()
                .map(|(w, n)| i128::from(*n) * i128::from(w[i]))
                .sum();
            let twice = 2 * num.abs() + total;
            let magnitude = twice / (2 * total);
            i64::try_from(if num < 0 { -magnitude } else { magnitude }).expect("fits")
        })
        .collect()
}

fn run(security: bool, txs: &[Tx]) -> Result<(), TestCaseError> {
    let p = params(security);
    let mut state = ContractState::genesis(&p);
    let mut accepted: Vec<(Arc<[i64]>, u64)> = Vec::new();
    let mut aggregations = 0u64;
    for (step, tx) in txs.iter().enumerate() {
        let before = state.clone();
        let outcome = state.execute(&p, tx.sender, tx.value_units, &tx.call);
        prop_assert_eq!(
            state.total_units(),
            p.total_units(),
            "conservation at step {}",
            step
        );
        let staked: u64 = state.submissions.iter().map(|s| s.stake_units).sum();
        prop_assert!(
            staked <= state.holdings_units,
            "the contract holds the round's stakes"
        );
        if !security {
            prop_assert_eq!(state.holdings_units, 0);
        }
        let mut senders: Vec<RobotId> = state.submissions.iter().map(|s| s.sender).collect();
        senders.sort_unstable();
        senders.dedup();
        prop_assert_eq!(
            senders.len(),
            state.submissions.len(),
            "one submission per robot per round"
        );

        if let Call::SubmitModel { weights, samples } = &tx.call {
            if (tx.sender as usize) < state.balances.len() && before.has_submitted(tx.sender) {
                prop_assert_eq!(&outcome, &Outcome::Duplicate);
            }
            if outcome.is_accepted() {
                accepted.push((weights.clone(), *samples));
            }
        }
        prop_assert_eq!(state.accepted_count() as usize, accepted.len() % 3);
        match &outcome {
            Outcome::Accepted {
                round,
                distance_units,
            } => {
                prop_assert_eq!(*round, before.round);
                prop_assert!(
                    before.accepted_count() + 1 < p.quorum,
                    "no aggregation before quorum"
                );
                prop_assert!(!security || u128::from(*distance_units) <= p.max_distance_units());
                prop_assert_eq!(&state.weights, &before.weights);
                prop_assert_eq!(state.round, before.round);
            }
            Outcome::Aggregated {
                round,
                distance_units,
                payouts,
            } => {
                prop_assert_eq!(*round, before.round);
                prop_assert_eq!(
                    before.accepted_count() + 1,
                    p.quorum,
                    "aggregation exactly at quorum"
                );
                prop_assert!(!security || u128::from(*distance_units) <= p.max_distance_units());
                prop_assert_eq!(state.round, before.round + 1);
                prop_assert_eq!(accepted.len(), 3);
                prop_assert_eq!(
                    &state.weights[..],
                    &expected_fedavg(&accepted)[..],
                    "only accepted models"
                );
                prop_assert_eq!(state.previous_weights.as_ref(), Some(&before.weights));
                prop_assert!(state.submissions.is_empty());
                prop_assert_eq!(payouts.len(), if security { 3 } else { 0 });
                let paid: u64 = payouts.iter().map(|p| p.units).sum();
                let last = state.last_round.as_deref().expect("recorded");
                prop_assert_eq!(last.pool_units - paid, last.carried_units);
                prop_assert_eq!(state.holdings_units, last.carried_units);
                prop_assert!(
                    last.carried_units < 3 + STAKE,
                    "only rounding and outlier stakes stay"
                );
                accepted.clear();
                aggregations += 1;
            }
            Outcome::Outlier {
                round,
                distance_units,
            } => {
                prop_assert!(security, "no outliers with security off");
                prop_assert_eq!(*round, before.round);
                prop_assert!(u128::from(*distance_units) > p.max_distance_units());
                prop_assert_eq!(&state.weights, &before.weights);
                prop_assert_eq!(state.accepted_count(), before.accepted_count());
                let last = state.submissions.last().expect("recorded");
                prop_assert_eq!(last.verdict, Verdict::Outlier);
                prop_assert_eq!(
                    state.balances[tx.sender as usize],
                    before.balances[tx.sender as usize] - STAKE
                );
            }
            Outcome::Transferred => {
                prop_assert_eq!(&state.weights, &before.weights);
                prop_assert_eq!(&state.submissions, &before.submissions);
            }
            Outcome::Duplicate
            | Outcome::InsufficientStake
            | Outcome::InsufficientFunds
            | Outcome::Malformed(_)
            | Outcome::OverGasLimit { .. }
            | Outcome::OutOfGas { .. } => {
                prop_assert_eq!(&state, &before, "a failed call changed the state");
            }
            // The buffered protocol's refusals: these rounds send no `submitUpdate`.
            Outcome::Refused(r) => prop_assert!(false, "a refusal under rounds: {r:?}"),
        }
    }
    prop_assert_eq!(state.round, aggregations);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn contract_invariants_hold_with_security_on(txs in transactions()) {
        run(true, &txs)?;
    }

    #[test]
    fn contract_invariants_hold_with_security_off(txs in transactions()) {
        run(false, &txs)?;
    }
}

/// A long honest run: every robot submits in turn, round after round, so balances drift apart,
/// the carried remainder is exercised across many rounds, and robots that fall below the stake
/// are refused until a transfer brings them back.
#[test]
fn many_rounds_of_honest_submissions_conserve_tokens() {
    let p = params(true);
    let mut state = ContractState::genesis(&p);
    let mut refused = 0u32;
    for turn in 0..300u64 {
        for robot in 0..ROBOTS {
            let shared = state.weights.clone();
            let jitter = ((turn * 7 + u64::from(robot) * 13) % 40) as i64 * 1_000_000;
            let weights: Vec<i64> = shared.iter().map(|x| x + jitter - 20_000_000).collect();
            let samples = 1 + (turn + u64::from(robot) * 31) % 500;
            let submit = Call::SubmitModel {
                weights: weights.into(),
                samples,
            };
            let balance = state.balances[robot as usize];
            let outcome = state.execute(&p, robot, STAKE, &submit);
            assert_eq!(
                outcome == Outcome::InsufficientStake,
                balance < STAKE,
                "{outcome:?}"
            );
            assert!(
                outcome.is_accepted() || outcome == Outcome::InsufficientStake,
                "{outcome:?}"
            );
            assert_eq!(state.total_units(), p.total_units());
            if balance < STAKE {
                // The richest robot tops the poor one up, so that rounds keep closing.
                refused += 1;
                let richest = (0..ROBOTS).max_by_key(|&r| (state.balances[r as usize], r));
                let top_up = Call::Transfer {
                    to: robot,
                    amount_units: STAKE,
                };
                let richest = richest.expect("robots");
                assert_eq!(state.execute(&p, richest, 0, &top_up), Outcome::Transferred);
            }
        }
    }
    assert!(
        refused > 0,
        "the penalised lose their stake: some robot ran dry"
    );
    assert!(state.round >= 400, "round {}", state.round);
}

/// The generators reach every outcome, so the properties above are exercised on each branch.
#[test]
fn the_generated_sequences_reach_every_outcome() {
    use std::collections::BTreeMap;

    use proptest::strategy::ValueTree;
    use proptest::test_runner::{Config, TestRng, TestRunner};

    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::deterministic_rng(Default::default()),
    );
    let mut seen: BTreeMap<&'static str, u32> = BTreeMap::new();
    for security in [true, false] {
        let p = params(security);
        for _ in 0..40 {
            let txs = transactions()
                .new_tree(&mut runner)
                .expect("a sequence")
                .current();
            let mut state = ContractState::genesis(&p);
            for tx in &txs {
                *seen
                    .entry(
                        state
                            .execute(&p, tx.sender, tx.value_units, &tx.call)
                            .name(),
                    )
                    .or_default() += 1;
            }
        }
    }
    for name in [
        "accepted",
        "aggregated",
        "outlier",
        "duplicate",
        "insufficient_stake",
        "transferred",
        "insufficient_funds",
        "malformed",
    ] {
        assert!(
            seen.get(name).copied().unwrap_or(0) >= 5,
            "outcome {name} rarely generated: {seen:?}"
        );
    }
}

//! Differential tests: random rounds through the native contract and the bytecode; every
//! outcome, balance, the shared weights and the whole state digest must agree after every call.

use std::sync::Arc;

use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;

use super::super::test_support::{self, TOKEN};
use super::super::{Call, ClaimBound, ContractParams, ContractState, Outcome};
use super::*;
use crate::config::*;

/// A small random draw in `0..n`.
fn below(rng: &mut Pcg64, n: u64) -> u64 {
    rng.next_u64() % n
}

fn chance(rng: &mut Pcg64, percent: u64) -> bool {
    below(rng, 100) < percent
}

/// Random rules: swarm size, quorum, reward weights, threshold, security and options.
fn random_params(rng: &mut Pcg64, len: usize) -> ContractParams {
    let robots = 2 + below(rng, 9) as u32;
    let quorum = 1 + below(rng, u64::from(robots)) as u32;
    let mut reward_weights: Vec<i64> = (0..quorum).map(|_| below(rng, 11) as i64 - 4).collect();
    if !reward_weights.iter().any(|&k| k > 0) {
        reward_weights[0] = 1 + below(rng, 5) as i64;
    }
    let options = if chance(rng, 50) {
        ContractOptions::default()
    } else {
        ContractOptions {
            median: if chance(rng, 50) {
                MedianRule::Mean
            } else {
                MedianRule::Lower
            },
            fedavg_rounding: if chance(rng, 50) {
                FedAvgRounding::Truncate
            } else {
                FedAvgRounding::Nearest
            },
            int48_products: chance(rng, 50),
            threshold: if chance(rng, 50) {
                ThresholdRule::Strict
            } else {
                ThresholdRule::Inclusive
            },
            rank_key: if chance(rng, 50) {
                RankKey::Mae
            } else {
                RankKey::Distance
            },
            rank_ties: if chance(rng, 50) {
                RankTies::Quicksort
            } else {
                RankTies::Stable
            },
            payout_rounding: if chance(rng, 50) {
                PayoutRounding::Ratio1e9
            } else {
                PayoutRounding::Exact
            },
            pool: if chance(rng, 50) {
                PoolRule::Round
            } else {
                PoolRule::Carry
            },
            // SwarmFL.sol ranks around the median only (validation refuses the other order).
            rank_order: RankOrder::Median,
        }
    };
    let genesis: Vec<i64> = (0..len)
        .map(|_| below(rng, 2_000_000_001) as i64 - 1_000_000_000)
        .collect();
    // A deadline of up to a minute (blocks come up to 20 s apart), or none; a claim bound of
    // a few hundred samples, explicit or derived, or only the hard limit.
    let round_timeout_ms = if chance(rng, 30) {
        0
    } else {
        1 + below(rng, 60_000)
    };
    let claim_bound = if chance(rng, 40) {
        ClaimBound::default()
    } else {
        ClaimBound {
            max_samples: 1 + below(rng, 500),
            explicit: chance(rng, 50),
        }
    };
    ContractParams {
        initial_units: (5 + below(rng, 30)) * TOKEN + below(rng, 7),
        stake_units: (1 + below(rng, 6)) * TOKEN + below(rng, 3),
        security: chance(rng, 85),
        quorum,
        outlier_threshold_units: [0, 1, 1_000, 50_000_000][below(rng, 4) as usize],
        genesis_weights: genesis.into(),
        round_timeout_ms,
        claim_bound,
        options,
        ..test_support::params(robots, reward_weights, 0)
    }
}

/// A random call: mostly honest submissions near the shared model, with outliers, exact
/// threshold distances, ties, duplicates, malformed models, wrong stakes, unknown senders and
/// transfers (which also drain balances below the stake).
fn random_call(rng: &mut Pcg64, p: &ContractParams, s: &ContractState) -> (RobotId, u64, Call) {
    let robots = u64::from(p.robots);
    let sender = if chance(rng, 3) {
        p.robots + below(rng, 3) as u32
    } else {
        below(rng, robots) as u32
    };
    let mut value = p.stake_units;
    if chance(rng, 5) {
        value = below(rng, p.stake_units + 1);
    } else if chance(rng, 3) {
        value = p.stake_units + 1 + below(rng, 10);
    }
    if chance(rng, 8) {
        let to = if chance(rng, 10) {
            p.robots + 1
        } else {
            below(rng, robots) as u32
        };
        let balance = s.balances.get(sender as usize).copied().unwrap_or(0);
        let amount = if chance(rng, 20) {
            balance + 1 + below(rng, 5)
        } else {
            below(rng, balance + 1)
        };
        let value = if chance(rng, 10) { 1 } else { 0 };
        return (
            sender,
            value,
            Call::Transfer {
                to,
                amount_units: amount,
            },
        );
    }
    let n = p.model_len() as u64;
    let max = p.max_distance_units() as u64;
    // Shapes of the model: near (within the threshold), exactly at it, just past it, far, a
    // copy of the shared model (ties), or hostile.
    let mut w: Vec<i64> = s.weights.to_vec();
    match below(rng, 10) {
        0..=4 => {
            let budget = max.max(1);
            for x in w.iter_mut() {
                let step = below(rng, 2 * (budget / n).max(1) + 1) as i64 - (budget / n) as i64;
                *x = (*x + step).clamp(-(1 << 46), 1 << 46);
            }
        }
        5 => {
            // Exactly at the threshold (in the first weight), or one unit past it.
            let extra = below(rng, 2);
            w[0] = w[0].saturating_add((max + extra) as i64).min((1 << 47) - 1);
        }
        6 => {}
        7 => {
            for x in w.iter_mut() {
                *x = below(rng, 1 << 47) as i64 - (1 << 46);
            }
        }
        8 => {
            let i = below(rng, n) as usize;
            w[i] = [
                1 << 47,
                -(1 << 47),
                (1 << 47) - 1,
                -(1 << 47) + 1,
                i64::MIN,
                i64::MAX,
            ][below(rng, 6) as usize];
        }
        _ => {
            if chance(rng, 50) {
                w.push(0);
            } else {
                w.pop();
            }
        }
    }
    let bound = p.claim_bound.max_samples;
    let samples = match below(rng, 14) {
        0 => 0,
        1 => u64::from(u32::MAX) + below(rng, 3),
        2 => 1 + below(rng, 1 << 24),
        // At the claim bound, or one past it.
        3 => bound + below(rng, 2),
        _ => 1 + below(rng, 400),
    };
    (
        sender,
        value,
        Call::SubmitModel {
            weights: Arc::from(w),
            samples,
        },
    )
}

fn assert_same(native: &ContractState, evm: &ContractState, context: &str) {
    assert_eq!(native.balances, evm.balances, "balances: {context}");
    assert_eq!(
        native.holdings_units, evm.holdings_units,
        "holdings: {context}"
    );
    assert_eq!(native.round, evm.round, "round: {context}");
    assert_eq!(native.weights, evm.weights, "weights: {context}");
    assert_eq!(
        native.submissions, evm.submissions,
        "submissions: {context}"
    );
    assert_eq!(native.last_round, evm.last_round, "last round: {context}");
    assert_eq!(
        (native.block_time_ms, native.round_opened_ms),
        (evm.block_time_ms, evm.round_opened_ms),
        "deadline clock: {context}"
    );
    assert_eq!(
        (native.rounds_timed_out, native.timeout_refunded_units),
        (evm.rounds_timed_out, evm.timeout_refunded_units),
        "deadlines: {context}"
    );
    assert_eq!(native.digest(), evm.digest(), "digest: {context}");
}

/// Runs random calls through both engines until `rounds` aggregations happened; returns the
/// rounds, the calls made and the rounds closed by a deadline.
fn differential(seed: u64, rounds: u64, len: usize) -> (u64, u64, u64) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (mut done, mut calls, mut timed_out) = (0u64, 0u64, 0u64);
    while done < rounds {
        let p = random_params(&mut rng, len);
        let pe = ContractParams {
            engine: ContractEngine::Evm,
            ..p.clone()
        };
        let mut native = ContractState::genesis(&p);
        let mut evm = ContractState::genesis(&pe);
        assert_same(&native, &evm, "genesis");
        // A scenario ends after some rounds, or when its balances no longer allow any.
        let target = done + 1 + below(&mut rng, 12);
        let mut stalled = 0;
        while done < target && stalled < 200 {
            // A new block now and then: the block time, and the round's opening time after an
            // aggregation, are part of the state (and its digest) in both engines.
            if chance(&mut rng, 30) {
                let now_ms = native.block_time_ms + 1 + below(&mut rng, 20_000);
                let before = native.rounds_timed_out;
                native.enter_block(&p, now_ms);
                evm.enter_block(&pe, now_ms);
                timed_out += native.rounds_timed_out - before;
                assert_same(&native, &evm, &format!("seed {seed}, block at {now_ms} ms"));
            }
            let (sender, value, call) = random_call(&mut rng, &p, &native);
            let a = native.execute(&p, sender, value, &call);
            let b = evm.execute(&pe, sender, value, &call);
            let context =
                format!("seed {seed}, call {calls}: {p:?}, sender {sender}, value {value}");
            assert_eq!(a, b, "outcome: {context}");
            assert_same(&native, &evm, &context);
            calls += 1;
            stalled += 1;
            if matches!(a, Outcome::Aggregated { .. }) {
                done += 1;
                stalled = 0;
            }
            if chance(&mut rng, 1) {
                native.restart_round();
                evm.restart_round();
                assert_same(&native, &evm, &format!("restart: {context}"));
            }
        }
        if stalled >= 200 {
            // Drained swarms stop aggregating; a new scenario continues the count.
            continue;
        }
    }
    (done, calls, timed_out)
}

#[test]
fn a_thousand_random_rounds_agree_on_every_call() {
    let (rounds, calls, timed_out) = differential(19, 1000, 6);
    assert!(rounds >= 1000);
    assert!(calls >= rounds);
    assert!(timed_out >= 10, "deadlines fired {timed_out} times");
}

/// Issue 37, finding 2, on the EVM: nine outliers and six accepted models stall a round of
/// quorum 7 in a swarm of 15; the Solidity contract closes it at its deadline and refunds the
/// accepted stakes exactly as the native one, and everyone may submit again.
#[test]
fn the_evm_contract_closes_a_stalled_round_at_its_deadline() {
    let p = ContractParams {
        round_timeout_ms: 300_000,
        ..test_support::params(15, vec![1, 1, 1, 1, 1, -1, -1], 4)
    };
    let pe = ContractParams {
        engine: ContractEngine::Evm,
        ..p.clone()
    };
    let mut native = ContractState::genesis(&p);
    let mut evm = ContractState::genesis(&pe);
    let submit = |w: i64| Call::SubmitModel {
        weights: Arc::from(vec![w; 4]),
        samples: 10,
    };
    for (params, s) in [(&p, &mut native), (&pe, &mut evm)] {
        s.enter_block(params, 10_000);
        for r in 0..15 {
            let w = if r < 9 { 400_000_000 } else { 1_000 };
            s.execute(params, r, 5 * TOKEN, &submit(w));
        }
        assert_eq!(
            s.holdings_units,
            75 * TOKEN,
            "{:?}: 15 stakes locked",
            params.engine
        );
        s.enter_block(params, 299_999);
        assert_eq!(s.submissions.len(), 15, "not yet");
        s.enter_block(params, 300_000);
        assert_eq!(s.rounds_timed_out, 1, "{:?}", params.engine);
        assert_eq!(s.holdings_units, 45 * TOKEN, "the outliers' stakes stay");
        let again = s.execute(params, 9, 5 * TOKEN, &submit(1_000));
        assert!(matches!(again, Outcome::Accepted { .. }), "{again:?}");
    }
    assert_same(&native, &evm, "after the deadline");
    let gas = &evm.evm.as_ref().expect("evm state").gas;
    assert_eq!(gas["enter_block"].calls, 3, "{gas:?}");
}

/// Issue 37, finding 1, on the EVM: a claim above the bound is refused with the same reason by
/// both engines and changes nothing; a claim at the bound is accepted.
#[test]
fn the_evm_contract_refuses_a_claim_above_the_bound() {
    let mut rng = Pcg64::seed_from_u64(5);
    let p = ContractParams {
        security: true,
        initial_units: 21 * TOKEN,
        stake_units: 5 * TOKEN,
        options: ContractOptions::default(),
        claim_bound: ClaimBound {
            max_samples: 851,
            explicit: false,
        },
        ..random_params(&mut rng, 4)
    };
    let pe = ContractParams {
        engine: ContractEngine::Evm,
        ..p.clone()
    };
    let mut native = ContractState::genesis(&p);
    let mut evm = ContractState::genesis(&pe);
    let call = |samples: u64| Call::SubmitModel {
        weights: p.genesis_weights.clone(),
        samples,
    };
    let a = native.execute(&p, 0, p.stake_units, &call(1_000_000_000));
    let b = evm.execute(&pe, 0, p.stake_units, &call(1_000_000_000));
    assert_eq!(
        a,
        Outcome::Malformed(
            "samples 1000000000 exceed the claim bound 851 (contract.max_claimed_samples)".into()
        )
    );
    assert_eq!(a, b);
    assert_same(&native, &evm, "refused");
    assert_eq!(native.balances[0], p.initial_units, "no stake taken");
    let a = native.execute(&p, 0, p.stake_units, &call(851));
    let b = evm.execute(&pe, 0, p.stake_units, &call(851));
    assert!(a.is_accepted(), "{a:?}");
    assert_eq!(a, b);
    assert_same(&native, &evm, "at the bound");
}

#[test]
fn full_size_models_agree() {
    // The paper's model length: 2848 weights, a few rounds.
    differential(7, 6, 2848);
}

#[test]
fn changed_rules_are_configured_on_the_evm() {
    let mut rng = Pcg64::seed_from_u64(3);
    let p = random_params(&mut rng, 4);
    let pe = ContractParams {
        engine: ContractEngine::Evm,
        ..p.clone()
    };
    let mut native = ContractState::genesis(&p);
    let mut evm = ContractState::genesis(&pe);
    let q = ContractParams {
        security: !p.security,
        stake_units: p.stake_units + 7,
        options: ContractOptions::authors(),
        ..p.clone()
    };
    let qe = ContractParams {
        engine: ContractEngine::Evm,
        ..q.clone()
    };
    for i in 0..200 {
        let (params, params_evm) = if i < 100 { (&p, &pe) } else { (&q, &qe) };
        if i == 100 {
            native.restart_round();
            evm.restart_round();
        }
        let (sender, value, call) = random_call(&mut rng, params, &native);
        let a = native.execute(params, sender, value, &call);
        let b = evm.execute(params_evm, sender, value, &call);
        assert_eq!(a, b, "call {i}");
        assert_same(&native, &evm, &format!("call {i}"));
    }
    let gas = &evm.evm.as_ref().expect("evm state").gas;
    assert_eq!(gas["configure"].calls, 1, "{gas:?}");
}

#[test]
fn the_binding_matches_the_committed_abi() {
    let artefact: serde_json::Value = serde_json::from_str(ARTEFACT_JSON).expect("json");
    let abi = artefact["abi"].as_array().expect("an abi array");
    let signature = |item: &serde_json::Value| -> String {
        let inputs: Vec<&str> = item["inputs"]
            .as_array()
            .expect("inputs")
            .iter()
            .map(|i| i["type"].as_str().expect("type"))
            .collect();
        format!(
            "{}({})",
            item["name"].as_str().unwrap_or(""),
            inputs.join(",")
        )
    };
    let names: Vec<String> = abi.iter().map(signature).collect();
    for used in [
        "submitModel(int64[],uint64,uint64)",
        "transfer(address,uint64,uint64)",
        "restartRound()",
        "configure(uint64,bool,uint32,uint256,int64[],uint256,uint64,uint64)",
        "enterBlock(uint64)",
        "deadline()",
        "state()",
        "getModel()",
        "getSubmissions()",
        "Paid(uint32,uint32,int64,uint64)",
        "Aggregated(uint64,uint64,uint64)",
        "(address[],uint64,int64[],uint64,bool,uint32,uint256,int64[],uint256,uint64,uint64)",
    ] {
        assert!(names.iter().any(|n| n == used), "{used} not in {names:?}");
    }
}

#[test]
fn a_submission_over_the_block_gas_limit_is_refused_and_changes_nothing() {
    // The paper's model length. The first accepted submission writes the round's FedAvg sum
    // into storage slots that are still zero, the dearest call of a run (about 39.6M gas).
    // Fixed parameters (not a random draw, whose claim bound, deadline and options may refuse
    // the submission for other reasons): three robots, a quorum of three so that the first
    // submission does not aggregate, one reward weight per rank, no deadline, the default
    // claim bound and options, a genesis model with no zero weight.
    let genesis: Vec<i64> = (0..2848i64)
        .map(|i| (i % 97 - 48) * 10_000_000 + 1)
        .collect();
    let p = ContractParams {
        genesis_weights: genesis.into(),
        engine: ContractEngine::Evm,
        ..test_support::params(3, vec![1, 1, 1], 0)
    };
    let submit = |weights: &Arc<[i64]>| Call::SubmitModel {
        weights: weights.clone(),
        samples: 100,
    };
    let model = ContractState::genesis(&p).weights.clone();

    // Without a binding limit (the authors' genesis value): accepted, and above 30M gas.
    let mut free = ContractState::genesis(&p);
    let outcome = free.execute(&p, 0, p.stake_units, &submit(&model));
    assert!(matches!(outcome, Outcome::Accepted { .. }), "{outcome:?}");
    assert_eq!(free.submissions.len(), 1);
    assert_eq!(free.balances[0], 16 * TOKEN, "the stake is taken");
    let used = free.evm.as_ref().unwrap().gas["accepted"].max_gas;
    assert!(used > 30_000_000, "{used} gas");

    // Mainnet's 30M: refused and counted, and nothing changed: balances, round, submissions,
    // the model and the contract's whole EVM storage (`ContractState`'s equality compares
    // it). The next submission meets the same zero slots, so it is refused too (under 30M
    // every submission of a run is).
    let tight = ContractParams {
        block_gas_limit: 30_000_000,
        ..p.clone()
    };
    let mut state = ContractState::genesis(&tight);
    let before = state.clone();
    assert_ne!(
        free, before,
        "an accepted submission changes the state, storage included"
    );
    for sender in 0..2 {
        let outcome = state.execute(&tight, sender, tight.stake_units, &submit(&model));
        assert_eq!(
            outcome,
            Outcome::OverGasLimit {
                gas_limit: 30_000_000
            }
        );
        assert_eq!(outcome.name(), "over_gas_limit");
        assert_eq!(state, before, "a refused call changed the state");
        assert_eq!(state.digest(), before.digest());
        assert_eq!(state.balances, before.balances);
        assert_eq!(state.round, 0);
        assert_eq!(state.submissions.len(), 0);
    }
    let gas = &state.evm.as_ref().unwrap().gas;
    assert_eq!(gas["over_gas_limit"].calls, 2, "{gas:?}");
    assert!(!gas.contains_key("accepted"), "{gas:?}");
    // The same submission under a limit a tenth above what it used: accepted.
    let enough = ContractParams {
        block_gas_limit: used + used / 10,
        ..p.clone()
    };
    let mut state = ContractState::genesis(&enough);
    let outcome = state.execute(&enough, 0, enough.stake_units, &submit(&model));
    assert!(matches!(outcome, Outcome::Accepted { .. }), "{outcome:?}");
    assert_eq!(
        state, free,
        "the same call under a limit it fits makes the same state"
    );
    // A limit below the calldata's own cost is refused before execution, the same way.
    let tiny = ContractParams {
        block_gas_limit: 21_000,
        ..p.clone()
    };
    let mut state = ContractState::genesis(&tiny);
    assert_eq!(
        state.execute(&tiny, 0, tiny.stake_units, &submit(&model)),
        Outcome::OverGasLimit { gas_limit: 21_000 }
    );
    assert_eq!(state.balances, ContractState::genesis(&tiny).balances);
    let gas = &state.evm.as_ref().unwrap().gas;
    assert_eq!(gas["over_gas_limit"].calls, 1, "{gas:?}");
    // A transfer fits in any such block.
    let transfer = Call::Transfer {
        to: 1,
        amount_units: 1,
    };
    assert_eq!(state.execute(&tight, 0, 0, &transfer), Outcome::Transferred);
}

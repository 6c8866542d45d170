//! `contract.gas_limit = "estimate"`: a transaction's gas limit is the estimate its node made
//! on the state it held, plus the margin; a call that lands where it needs more runs out of
//! gas and reverts.

use std::sync::Arc;

use super::super::test_support::{self, TOKEN};
use super::super::{Call, ContractParams, ContractState, Outcome};
use super::{estimate, TxGas};
use crate::config::{ContractEngine, WEB3_GAS_MARGIN};
use crate::types::RobotId;

/// Three robots, a round of two (paper-length models), the evm engine.
fn params() -> ContractParams {
    ContractParams {
        engine: ContractEngine::Evm,
        ..test_support::params(3, vec![1, 1], 2848)
    }
}

fn submit(offset: i64) -> Call {
    let weights: Arc<[i64]> = (0..2848).map(|i| 1_000 + offset + (i % 7)).collect();
    Call::SubmitModel {
        weights,
        samples: 100,
    }
}

/// The state after one whole round (robots 0 and 1), so the running sum's slots are no longer
/// zero and a round's first submission costs what any plain one does.
fn after_one_round(p: &ContractParams) -> ContractState {
    let mut s = ContractState::genesis(p);
    assert!(s.execute(p, 0, p.stake_units, &submit(0)).is_accepted());
    let closing = s.execute(p, 1, p.stake_units, &submit(3));
    assert!(matches!(closing, Outcome::Aggregated { .. }), "{closing:?}");
    s
}

/// `seen` with robot 0's submission of the round landed on it: the state robot 1's call lands
/// on when its node had not seen robot 0's.
fn with_robot_0s_submission(p: &ContractParams, seen: &ContractState) -> ContractState {
    let mut landed = seen.clone();
    assert!(landed
        .execute(p, 0, p.stake_units, &submit(1))
        .is_accepted());
    landed
}

/// Robot 1's submission estimated on `seen` (its node's head) with `margin`, executed on
/// `landed` (the block that includes it).
fn send(
    p: &ContractParams,
    seen: &ContractState,
    landed: &mut ContractState,
    margin: u64,
) -> (TxGas, Outcome) {
    let sender: RobotId = 1;
    let call = submit(5);
    let gas = estimate(seen, p, sender, p.stake_units, &call, margin).unwrap();
    let outcome = landed.execute_with_gas(p, sender, p.stake_units, &call, Some(gas.limit));
    (gas, outcome)
}

#[test]
fn a_submission_estimated_as_plain_that_closes_the_round_runs_out_of_gas_and_reverts() {
    let p = params();
    let seen = after_one_round(&p);
    // Robot 0's submission lands first; robot 1's node has not seen it.
    let mut landed = with_robot_0s_submission(&p, &seen);
    let before = landed.clone();
    let (gas, outcome) = send(&p, &seen, &mut landed, WEB3_GAS_MARGIN);
    assert_eq!(gas.limit, gas.estimate + WEB3_GAS_MARGIN);
    assert_eq!(
        outcome,
        Outcome::OutOfGas {
            gas_limit: gas.limit
        }
    );
    assert_eq!(outcome.name(), "out_of_gas");
    // Reverted: the state is robot 0's submission alone, the stake is back with robot 1,
    // and every unit is accounted for.
    assert_eq!(
        landed.digest(),
        before.digest(),
        "the revert changed the state"
    );
    assert_eq!(landed.balances, before.balances);
    assert_eq!(landed.submissions.len(), 1);
    assert!(
        !landed.has_submitted(1),
        "robot 1's turn left no submission"
    );
    assert_eq!(landed.total_units(), p.total_units());
    let evm = landed.evm.as_ref().unwrap();
    assert_eq!(evm.gas["out_of_gas"].calls, 1);
    assert_eq!(evm.gas["out_of_gas"].total_gas, gas.limit);
    let trace = evm.block_calls.last().unwrap();
    assert!(trace.included && !trace.success && trace.gas == gas.limit);

    // Estimated on the state the call lands on, it closes the round within its limit.
    let mut informed = before.clone();
    let (gas_there, closing) = send(&p, &before, &mut informed, WEB3_GAS_MARGIN);
    assert!(matches!(closing, Outcome::Aggregated { .. }), "{closing:?}");
    assert!(
        gas_there.estimate > gas.estimate + WEB3_GAS_MARGIN,
        "closing {} against plain {}: the aggregation costs more than the margin",
        gas_there.estimate,
        gas.estimate
    );
}

#[test]
fn with_a_margin_above_the_aggregations_extra_gas_the_submission_closes_the_round() {
    let p = params();
    let seen = after_one_round(&p);
    let mut landed = with_robot_0s_submission(&p, &seen);
    let (_, outcome) = send(&p, &seen, &mut landed, 20_000_000);
    assert!(matches!(outcome, Outcome::Aggregated { .. }), "{outcome:?}");
    assert_eq!(landed.round, seen.round + 1);
    assert_eq!(landed.total_units(), p.total_units());
    // Its estimate on the state it lands on is exactly enough: not one gas short.
    let mut exact = with_robot_0s_submission(&p, &seen);
    let (gas, outcome) = send(&p, &exact.clone(), &mut exact, 0);
    assert!(matches!(outcome, Outcome::Aggregated { .. }), "{outcome:?}");
    let mut short = with_robot_0s_submission(&p, &seen);
    let call = submit(5);
    let outcome = short.execute_with_gas(&p, 1, p.stake_units, &call, Some(gas.limit - 1));
    assert!(matches!(outcome, Outcome::OutOfGas { .. }), "{outcome:?}");
}

#[test]
fn an_estimate_leaves_the_node_state_alone_and_a_limit_above_the_block_is_refused() {
    let p = params();
    let seen = after_one_round(&p);
    let digest = seen.digest();
    let gas = estimate(&seen, &p, 2, p.stake_units, &submit(2), WEB3_GAS_MARGIN).unwrap();
    assert_eq!(seen.digest(), digest);
    assert!(gas.estimate > 1_000_000, "{gas:?}");
    // web3.py caps the limit at the block's.
    let tight = ContractParams {
        block_gas_limit: gas.estimate + 10,
        ..p.clone()
    };
    let capped = estimate(&seen, &tight, 2, p.stake_units, &submit(2), WEB3_GAS_MARGIN).unwrap();
    assert_eq!(capped.limit, tight.block_gas_limit);
    // A call that cannot complete within a block fails the estimate: nothing is sent.
    let tiny = ContractParams {
        block_gas_limit: gas.estimate / 2,
        ..p.clone()
    };
    let failed = estimate(&seen, &tiny, 2, p.stake_units, &submit(2), WEB3_GAS_MARGIN);
    assert_eq!(failed.map_err(|e| e.outcome), Err("over_gas_limit"));
    // A transaction asking for more than a block holds is never included.
    let mut s = seen.clone();
    let over = s.execute_with_gas(&tight, 2, p.stake_units, &submit(2), Some(gas.limit));
    assert_eq!(
        over,
        Outcome::OverGasLimit {
            gas_limit: tight.block_gas_limit
        }
    );
    assert_eq!(s.digest(), digest);
    // A transaction's limit binds only the evm engine: the native one has no gas.
    let native = ContractParams {
        engine: ContractEngine::Native,
        ..p.clone()
    };
    let mut n = ContractState::genesis(&native);
    assert!(n
        .execute_with_gas(&native, 0, TOKEN * 5, &submit(0), Some(21_000))
        .is_accepted());
}

#[test]
fn a_call_the_contract_refuses_fails_its_estimate() {
    let p = params();
    let mut s = after_one_round(&p);
    assert!(s.execute(&p, 0, p.stake_units, &submit(1)).is_accepted());
    let refused = |seen: &ContractState, sender: RobotId, value: u64, call: &Call| {
        estimate(seen, &p, sender, value, call, WEB3_GAS_MARGIN).map_err(|e| e.outcome)
    };
    // Robot 0 submitted in this round (the authors' `require(!participates)`).
    assert_eq!(refused(&s, 0, p.stake_units, &submit(2)), Err("duplicate"));
    // A stake below the contract's (`require(msg.value >= aggregationPrice)`).
    assert_eq!(
        refused(&s, 2, p.stake_units - 1, &submit(2)),
        Err("insufficient_stake")
    );
    // No samples (`require(nbSamples > 0)`).
    let zero = Call::SubmitModel {
        weights: (0..2848).map(|i| 1_000 + (i % 7)).collect(),
        samples: 0,
    };
    assert_eq!(refused(&s, 2, p.stake_units, &zero), Err("malformed"));
    // A fresh robot's submission estimates.
    assert!(refused(&s, 2, p.stake_units, &submit(2)).is_ok());
}

//! `contract.gas_limit = "estimate"`, the sending side: a robot's transaction gets its gas
//! when the robot sends it (after its training, as the authors' `transact` call comes after
//! the training returns), from its node's estimate on the state `contract.gas_estimate_state`
//! names; when the estimate fails the robot sends nothing (`contract::gas_limit`).

use std::borrow::Cow;

use crate::config::{ContractConfig, GasEstimateState};
use crate::contract::gas_limit::{self, EstimateFailed};
use crate::ledger::Tx;
use crate::metrics::{LearnAction, LearnReport, SkipReason};
use crate::state::State;
use crate::types::SimTime;

/// The transaction `draft` (made when the robot's phase began) as its robot sends it at `now`:
/// signed again with the nonce its node gives now and the gas limit its node estimates on its
/// pending block's state or its head's, or why the estimate failed.
pub(super) fn sent(
    state: &State,
    contract: &ContractConfig,
    draft: &Tx,
    now: SimTime,
) -> Result<Tx, EstimateFailed> {
    let ledger = &state.ledger;
    let robot = draft.sender;
    let seen = match contract.gas_estimate_state {
        GasEstimateState::Pending => {
            let recommit_ms = (contract.gas_recommit_s * 1000.0).round() as u64;
            Cow::Owned(ledger.pending_state(robot, now, recommit_ms))
        }
        GasEstimateState::Head => Cow::Borrowed(ledger.head_state(robot)),
    };
    let params = ledger.current_params();
    let gas = gas_limit::estimate(
        &seen,
        params,
        robot,
        draft.value_units,
        &draft.call,
        contract.gas_margin,
    )?;
    Ok(ledger.make_tx_with_gas(robot, draft.value_units, draft.call.clone(), Some(gas)))
}

/// `report` with its transaction `sent` (its id replaced), or, when the estimate failed, a
/// phase skipped for it (`estimate_failed`).
pub(super) fn reported(mut report: LearnReport, sent: Result<&Tx, EstimateFailed>) -> LearnReport {
    match (sent, &mut report.action) {
        (Ok(tx), LearnAction::Trained { tx: id, .. } | LearnAction::Forged { tx: id, .. }) => {
            *id = tx.hash_and_size().0;
        }
        (Err(_), _) => {
            report.action = LearnAction::Skipped {
                reason: SkipReason::EstimateFailed,
            };
        }
        (Ok(_), LearnAction::Skipped { .. }) => {}
    }
    report
}

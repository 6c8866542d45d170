//! `contract.gas_limit = "estimate"`: the authors' gas limits (engine `evm` only).
//!
//! The authors' robots send every transaction through web3.py without a `gas` field, so
//! web3.py fills it with `get_buffered_gas_estimate`: the node's `eth_estimateGas` of the call
//! plus a buffer of 100,000, capped at the block gas limit (`web3/_utils/transactions.py`).
//! The estimate runs the call on the state the sender's node holds when it sends; the
//! transaction then executes in whatever block includes it, on that block's state. The
//! authors' contract spends more on the submission that completes the round (it aggregates,
//! pays and resets: `processWeights` of `TrajectoryPrediction/scs/federatedsc3V2.sol`,
//! lines 105-115) than on one that only adds to the running sum, by far more than 100,000,
//! so a submission estimated as a plain one that lands as the closing one runs out of gas and
//! reverts. docs/CONTRACT.md ("Gas", "The authors' gas limits").
//!
//! [`estimate`] is the driver's side (the sender's node, when the robot sends its
//! transaction, on its pending block's state or its head's, `contract.gas_estimate_state`):
//! the gas limit it writes into the transaction ([`TxGas`], recorded in the log, so replay
//! derives nothing), or the failure that keeps the robot from sending ([`EstimateFailed`]). The transaction's execution ([`ContractState::execute_with_gas`])
//! runs the call with that limit; out of gas it reverts ([`Outcome::OutOfGas`]): the contract's
//! state is unchanged, so the stake never left the sender.

use serde::{Deserialize, Serialize};

use super::{evm, Call, ContractParams, ContractState};
use crate::types::RobotId;

/// The gas a transaction carries: the estimate its sender's node made and the limit it set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TxGas {
    /// The gas the call used on the state of the sender's node when it was sent (what
    /// `eth_estimateGas` answers: spent before refunds, at least the calldata floor).
    pub estimate: u64,
    /// The transaction's gas limit: `min(estimate + contract.gas_margin, block gas limit)`.
    pub limit: u64,
}

/// Why a node's estimate failed, so that its robot sent nothing: web3.py raises when
/// `eth_estimateGas` fails, and the authors' controller catches the exception and moves on
/// (`controllers/docker/fedlerv2.py`, lines 199-202 and 221-224).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EstimateFailed {
    /// The outcome the call had on the estimated state ([`Outcome::name`]: `duplicate`,
    /// `insufficient_stake`, `insufficient_funds`, `malformed`, or `over_gas_limit` for a
    /// call that cannot complete within a block).
    ///
    /// [`Outcome::name`]: super::Outcome::name
    pub outcome: &'static str,
}

/// The gas limit `sender`'s node gives its transaction `call` (with `value_units` attached)
/// when the state it estimates on is `seen` (its head's, or its pending block's) and the
/// rules are `params`: the call's estimate on `seen` plus `margin`, capped at the block gas
/// limit as web3.py caps it. `Err` when the estimate fails (the contract refuses the call,
/// or it cannot complete within a block): the robot sends nothing. `seen` is not changed
/// (the estimate runs on a copy). Only for a state that holds an EVM (`contract.engine =
/// "evm"`; validation refuses `contract.gas_limit = "estimate"` otherwise).
pub fn estimate(
    seen: &ContractState,
    params: &ContractParams,
    sender: RobotId,
    value_units: u64,
    call: &Call,
    margin: u64,
) -> Result<TxGas, EstimateFailed> {
    let estimate = evm::estimate(seen, params, sender, value_units, call)
        .map_err(|outcome| EstimateFailed { outcome })?;
    Ok(TxGas {
        estimate,
        limit: estimate.saturating_add(margin).min(params.block_gas_limit),
    })
}

#[cfg(all(test, feature = "evm"))]
#[path = "gas_limit_tests.rs"]
mod tests;

//! `contract.engine = "evm"` in a build without the `evm` cargo feature: the engine is refused
//! by config validation with the command that builds it, so no state ever holds an EVM.
//!
//! The feature is off by default because revm and its precompile crates are about a third of
//! a fresh build (docs/PERFORMANCE.md, "Build time"); `--features evm` turns it on.

use super::{Call, ContractParams, ContractState, Outcome};
use crate::types::RobotId;

/// No EVM in this build: only [`EvmState::deploy`] could make one, and validation never lets it
/// run, so `ContractState::evm` is always `None`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EvmState(());

impl EvmState {
    /// Never called: validation refuses `contract.engine = "evm"` first
    /// ([`crate::config::Config::validate`]).
    pub fn deploy(_params: &ContractParams) -> EvmState {
        unreachable!("contract.engine = evm passed validation in a build without the evm feature")
    }
}

/// Never called: no state holds an EVM in this build.
pub fn execute(
    state: &mut ContractState,
    _params: &ContractParams,
    _sender: RobotId,
    _value_units: u64,
    _call: &Call,
    _tx_gas: Option<u64>,
) -> Outcome {
    unreachable!(
        "contract.engine = evm executed in a build without the evm feature (state holds an EVM: {})",
        state.evm.is_some()
    )
}

/// Never called: no state holds an EVM in this build.
pub fn restart_round(state: &mut ContractState) {
    unreachable!(
        "an EVM round restarted in a build without the evm feature (state holds an EVM: {})",
        state.evm.is_some()
    )
}

/// Never called: no state holds an EVM in this build.
pub fn enter_block(state: &mut ContractState, _params: &ContractParams, _timestamp_ms: u64) {
    unreachable!(
        "an EVM block entered in a build without the evm feature (state holds an EVM: {})",
        state.evm.is_some()
    )
}

/// Never called: validation refuses `contract.gas_limit = "estimate"` without the evm engine.
pub fn estimate(
    head: &ContractState,
    _params: &ContractParams,
    _sender: RobotId,
    _value_units: u64,
    _call: &Call,
) -> Result<u64, &'static str> {
    unreachable!(
        "a gas estimate in a build without the evm feature (state holds an EVM: {})",
        head.evm.is_some()
    )
}

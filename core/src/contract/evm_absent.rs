//! `contract.engine = "evm"` in a build without the `evm` cargo feature: the engine is refused
//! by config validation with the command that builds it, so no state ever holds an EVM.
//!
//! The feature is off by default because revm and its precompile crates are about a third of
//! a fresh build (docs/PERFORMANCE.md, "Build time"); `--features evm` turns it on.

use super::{Call, ContractParams, ContractState, Outcome};
use crate::config::{Config, ConfigError};
use crate::types::RobotId;

/// No EVM in this build: only [`EvmState::deploy`] could make one, and validation never lets it
/// run, so `ContractState::evm` is always `None`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EvmState(());

impl EvmState {
    /// Never called: validation refuses `contract.engine = "evm"` first ([`supports`]).
    pub fn deploy(_params: &ContractParams) -> EvmState {
        unreachable!("contract.engine = evm passed validation in a build without the evm feature")
    }
}

/// Refuses `contract.engine = "evm"`, naming the feature and the command that builds it.
pub fn supports(_config: &Config) -> Result<(), ConfigError> {
    Err(ConfigError::OutOfRange {
        key: "contract.engine".to_string(),
        value: "evm".to_string(),
        allowed: "native in this build of swarmfl, which was built without the EVM engine \
                  (cargo feature `evm`, off by default); rebuild with \
                  `cargo build --release -p replay-cli --features evm` to run \
                  contracts/SwarmFL.sol, or set contract.engine = native"
            .to_string(),
    })
}

/// Never called: no state holds an EVM in this build.
pub fn execute(
    state: &mut ContractState,
    _params: &ContractParams,
    _sender: RobotId,
    _value_units: u64,
    _call: &Call,
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

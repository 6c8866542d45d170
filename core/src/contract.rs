//! The smart contract, executed by every node on its own chain (SPEC.md section 4).
//!
//! This first cut is the minimal token-transfer contract that the ledger issue uses to exercise
//! the path; the contract issue replaces the bodies with the federated-learning rules while
//! keeping these signatures. Integer arithmetic only.

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::config::Config;
use crate::types::{Digest, RobotId};

/// Parameters of the contract, fixed at genesis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContractParams {
    /// Number of robots (accounts).
    pub robots: u32,
    /// Units every account holds at genesis.
    pub initial_units: u64,
    /// Stake per submission, in units.
    pub stake_units: u64,
    /// Security mechanisms on or off.
    pub security: bool,
    /// Accepted submissions per aggregation.
    pub quorum: u32,
    /// Outlier threshold in fixed-point units of the mean absolute distance.
    pub outlier_threshold_units: i64,
    /// Reward weight per rank (+1 / -1), best first.
    pub reward_weights: Vec<i64>,
    /// The genesis model, fixed point.
    pub genesis_weights: Arc<[i64]>,
}

impl ContractParams {
    /// The parameters of a run's contract.
    pub fn from_config(config: &Config, genesis_weights: Arc<[i64]>) -> ContractParams {
        let c = &config.contract;
        ContractParams {
            robots: config.world.robots,
            initial_units: c.initial_tokens * c.token_units,
            stake_units: c.stake_tokens * c.token_units,
            security: c.security,
            quorum: config.quorum(),
            outlier_threshold_units: (c.outlier_threshold * c.weight_scale as f64).round() as i64,
            reward_weights: config.reward_weights(),
            genesis_weights,
        }
    }
}

/// A call carried by a transaction.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Call {
    /// `submitModel(weights, n)`: a locally trained model (fixed point) and its sample count.
    SubmitModel {
        /// The weights, fixed point (scale `contract.weight_scale`).
        weights: Arc<[i64]>,
        /// Training samples claimed.
        samples: u64,
    },
    /// Moves `amount_units` from the sender to `to`.
    Transfer {
        /// Recipient account.
        to: RobotId,
        /// Amount in units.
        amount_units: u64,
    },
}

/// What became of one call.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Outcome {
    /// A transfer went through.
    Transferred,
    /// A transfer or call failed for lack of funds; nothing changed.
    InsufficientFunds,
    /// The call was malformed (reason given); nothing changed.
    Malformed(String),
}

/// The contract's state after some block: cheap to clone (large parts are shared).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContractState {
    /// Token balance of every account, in units.
    pub balances: Vec<u64>,
    /// Units held by the contract itself (pool plus carried remainders).
    pub holdings_units: u64,
    /// Aggregation round (the model's version).
    pub round: u64,
    /// The shared model, fixed point.
    pub weights: Arc<[i64]>,
}

impl ContractState {
    /// The state at genesis.
    pub fn genesis(params: &ContractParams) -> ContractState {
        ContractState {
            balances: vec![params.initial_units; params.robots as usize],
            holdings_units: 0,
            round: 0,
            weights: params.genesis_weights.clone(),
        }
    }

    /// Executes one call sent by `sender` with `value_units` attached.
    pub fn execute(
        &mut self,
        params: &ContractParams,
        sender: RobotId,
        value_units: u64,
        call: &Call,
    ) -> Outcome {
        let _ = (params, value_units);
        match call {
            Call::Transfer { to, amount_units } => {
                let (Some(&from_balance), true) =
                    (self.balances.get(sender as usize), (*to as usize) < self.balances.len())
                else {
                    return Outcome::Malformed(format!("no account {sender} or {to}"));
                };
                if from_balance < *amount_units {
                    return Outcome::InsufficientFunds;
                }
                self.balances[sender as usize] -= amount_units;
                self.balances[*to as usize] += amount_units;
                Outcome::Transferred
            }
            Call::SubmitModel { .. } => Outcome::Malformed("not yet supported".to_string()),
        }
    }

    /// Sum of all balances plus the contract's holdings: constant for a run.
    pub fn total_units(&self) -> u128 {
        self.balances.iter().map(|&b| u128::from(b)).sum::<u128>() + u128::from(self.holdings_units)
    }

    /// A digest of the whole state.
    pub fn digest(&self) -> Digest {
        let bytes = rmp_serde::to_vec(self).expect("contract state serialises");
        Digest::of(&bytes)
    }
}

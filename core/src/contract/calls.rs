//! A call a transaction carries and what becomes of it ([`Call`], [`Outcome`]), and the
//! records a round keeps of its submissions and payouts ([`Submission`], [`Verdict`],
//! [`Payout`], [`RoundSummary`]).

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::buffered;
use crate::types::{Digest, RobotId};

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
    /// `submitUpdate(weights, n, base)` (`contract.protocol = "buffered"`, [`buffered`]): a
    /// model trained from version `base_round`, whose digest the sender's chain showed as
    /// `base_digest`. A new variant, so the encoding of the other calls does not change.
    SubmitUpdate {
        /// The weights, fixed point.
        weights: Arc<[i64]>,
        /// Training samples claimed.
        samples: u64,
        /// The version trained from.
        base_round: u64,
        /// Its digest as the sender's chain showed it.
        base_digest: Digest,
    },
    /// Moves `amount_units` from the sender to `to`.
    Transfer {
        /// Recipient account.
        to: RobotId,
        /// Amount in units.
        amount_units: u64,
    },
}

/// One robot's payout at an aggregation.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Payout {
    /// The paid robot.
    pub robot: RobotId,
    /// Its rank, 0 = best.
    pub rank: u32,
    /// The reward weight k of that rank; under a defence (`contract.defence`), the
    /// submission's score in 10^9 units (10^9 = full agreement).
    pub reward_weight: i64,
    /// Units paid back to it from the pool.
    pub units: u64,
}

/// What became of one call.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Outcome {
    /// The model was accepted into round `round`; the round is not complete yet.
    Accepted {
        /// The round (model version) the submission counts for.
        round: u64,
        /// `sum_i |w_i - w_a,i|` in fixed-point units.
        distance_units: u64,
    },
    /// The model was accepted and completed the quorum: round `round` was aggregated (the model
    /// is now version `round + 1`) and the pool paid out.
    Aggregated {
        /// The round that closed.
        round: u64,
        /// This model's distance, as in `Accepted`.
        distance_units: u64,
        /// Payouts in rank order (empty with security off).
        payouts: Vec<Payout>,
    },
    /// Rejected as an outlier: the stake stays in the pool, the sender's turn is used.
    Outlier {
        /// The round the submission counted for.
        round: u64,
        /// The model's distance (above `threshold_units * N`).
        distance_units: u64,
    },
    /// The sender already submitted in this round; nothing changed.
    Duplicate,
    /// The stake was missing (value or balance below it); nothing changed.
    InsufficientStake,
    /// A transfer went through.
    Transferred,
    /// A transfer exceeded the sender's balance; nothing changed.
    InsufficientFunds,
    /// The call was malformed (reason given); nothing changed.
    Malformed(String),
    /// The call needs more gas than a block holds (`contract.block_gas_limit`, the `evm`
    /// engine only): no block can include it, so nothing changed.
    OverGasLimit {
        /// The block gas limit it exceeded.
        gas_limit: u64,
    },
    /// The buffered protocol refused the submission's base (reason given); no stake moved.
    Refused(buffered::Refusal),
    /// The call ran out of the gas its transaction carried (`contract.gas_limit =
    /// "estimate"`, the `evm` engine only): it reverted, so nothing changed (the stake stays
    /// with the sender), and the sender's turn is used.
    OutOfGas {
        /// The transaction's gas limit, all of it spent.
        gas_limit: u64,
    },
}

impl Outcome {
    /// A short stable name, for metrics and logs.
    pub fn name(&self) -> &'static str {
        match self {
            Outcome::Accepted { .. } => "accepted",
            Outcome::Aggregated { .. } => "aggregated",
            Outcome::Outlier { .. } => "outlier",
            Outcome::Duplicate => "duplicate",
            Outcome::InsufficientStake => "insufficient_stake",
            Outcome::Transferred => "transferred",
            Outcome::InsufficientFunds => "insufficient_funds",
            Outcome::Malformed(_) => "malformed",
            Outcome::OverGasLimit { .. } => "over_gas_limit",
            Outcome::Refused(r) => r.name(),
            Outcome::OutOfGas { .. } => "out_of_gas",
        }
    }

    /// True when a model was accepted (including the one that triggered an aggregation).
    pub fn is_accepted(&self) -> bool {
        matches!(self, Outcome::Accepted { .. } | Outcome::Aggregated { .. })
    }
}

/// The verdict on a counted submission.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Verdict {
    /// Within the threshold: part of the round's aggregate.
    Accepted,
    /// Beyond the threshold: excluded, stake kept by the pool.
    Outlier,
}

/// A submission that counts for its round (accepted or outlier).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Submission {
    /// The sender.
    pub sender: RobotId,
    /// Samples claimed.
    pub samples: u64,
    /// `sum_i |w_i - w_a,i|` against the model of the round.
    pub distance_units: u64,
    /// Units staked (0 with security off).
    pub stake_units: u64,
    /// Accepted or outlier.
    pub verdict: Verdict,
    /// The submitted weights (shared with the transaction, never copied).
    pub weights: Arc<[i64]>,
    /// blake3 of the weights, computed once.
    pub weights_digest: Digest,
}

/// The record of the last aggregated round.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RoundSummary {
    /// The round that closed (its models were trained on version `round`).
    pub round: u64,
    /// Its counted submissions in submission order.
    pub submissions: Vec<Submission>,
    /// Payouts in rank order (empty with security off).
    pub payouts: Vec<Payout>,
    /// The pool P that was distributed (round stakes plus the carried remainder).
    pub pool_units: u64,
    /// What stayed in the contract and rolls into the next pool: P - sum(payouts).
    pub carried_units: u64,
}

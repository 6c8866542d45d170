//! The contract's variants where swarmfl's rules and the authors' Solidity contract (geth-argos
//! `federatedsc3V2.sol`) differ; docs/CONTRACT.md has the table. The defaults are swarmfl's
//! rules; each option selects the authors' behaviour for one difference, in both engines.

use serde::{Deserialize, Serialize};

use super::rules::Rule;
use crate::config::{Config, ConfigError};

/// Which machine executes the contract.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ContractEngine {
    /// The Rust reducer of `contract/mod.rs`.
    #[default]
    Native,
    /// The Solidity contract of `contracts/SwarmFL.sol`, its committed bytecode run in revm.
    Evm,
}

/// The median of an even number of distances.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MedianRule {
    /// The lower middle `sorted[(q - 1) / 2]` (swarmfl).
    #[default]
    Lower,
    /// The floored mean of the two middles (authors).
    Mean,
}

/// How FedAvg's quotient is rounded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FedAvgRounding {
    /// To the nearest integer, ties away from zero (swarmfl).
    #[default]
    Nearest,
    /// Toward zero, Solidity's signed division (authors).
    Truncate,
}

/// When a distance equal to the threshold is accepted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ThresholdRule {
    /// Accepted iff `d <= threshold * N` (swarmfl, the paper's "<=").
    #[default]
    Inclusive,
    /// Accepted iff `d < threshold * N` (authors: `floor(d / N) < threshold`).
    Strict,
}

/// The distance the ranking is computed on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RankKey {
    /// The exact L1 distance `d` (swarmfl).
    #[default]
    Distance,
    /// The truncated mean absolute error `floor(d / N)` (authors), which creates ties.
    Mae,
}

/// How equal ranking keys are ordered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RankTies {
    /// Submission order (a stable sort; swarmfl).
    #[default]
    Stable,
    /// Whatever the authors' Hoare quicksort leaves (not stable).
    Quicksort,
}

/// How the reward and penalty shares are rounded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PayoutRounding {
    /// `floor(stake * k s / sum)` rewards, `ceil(..)` penalties (swarmfl: exact to one unit).
    #[default]
    #[serde(rename = "exact")]
    Exact,
    /// The share normalised to 1e9 and floored first, `stake * floor(1e9 k s / sum) / 1e9`,
    /// for rewards and penalties alike (authors).
    #[serde(rename = "ratio_1e9")]
    Ratio1e9,
}

/// What an aggregation distributes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PoolRule {
    /// Everything the contract holds: the round's stakes plus earlier remainders (swarmfl).
    #[default]
    Carry,
    /// The round's stakes only; remainders stay in the contract for good (authors).
    Round,
}

/// Every variant option of the contract (all default: swarmfl's rules).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContractOptions {
    /// `contract.median`.
    pub median: MedianRule,
    /// `contract.fedavg_rounding`.
    pub fedavg_rounding: FedAvgRounding,
    /// `contract.int48_products`: refuse an accepted model when some `w_i * n`, or the round's
    /// running sum with it, leaves int48 (the authors' `int48` accumulator under Solidity 0.8's
    /// checked arithmetic reverts such a submission).
    pub int48_products: bool,
    /// `contract.threshold`.
    pub threshold: ThresholdRule,
    /// `contract.rank_key`.
    pub rank_key: RankKey,
    /// `contract.rank_ties`.
    pub rank_ties: RankTies,
    /// `contract.payout_rounding`.
    pub payout_rounding: PayoutRounding,
    /// `contract.pool`.
    pub pool: PoolRule,
}

impl ContractOptions {
    /// True for swarmfl's own rules (every option at its default).
    pub fn is_default(&self) -> bool {
        *self == ContractOptions::default()
    }

    /// The option bits of `contracts/SwarmFL.sol` (its `flags`).
    pub fn flags(&self) -> u64 {
        let mut f = 0;
        let mut set = |on: bool, bit: u64| {
            if on {
                f |= bit;
            }
        };
        set(self.median == MedianRule::Mean, 1);
        set(self.fedavg_rounding == FedAvgRounding::Truncate, 2);
        set(self.int48_products, 4);
        set(self.threshold == ThresholdRule::Strict, 8);
        set(self.rank_key == RankKey::Mae, 16);
        set(self.rank_ties == RankTies::Quicksort, 32);
        set(self.payout_rounding == PayoutRounding::Ratio1e9, 64);
        set(self.pool == PoolRule::Round, 128);
        f
    }

    /// The authors' contract in every respect (with `contract.reward_weights` separately).
    pub fn authors() -> ContractOptions {
        ContractOptions {
            median: MedianRule::Mean,
            fedavg_rounding: FedAvgRounding::Truncate,
            int48_products: true,
            threshold: ThresholdRule::Strict,
            rank_key: RankKey::Mae,
            rank_ties: RankTies::Quicksort,
            payout_rounding: PayoutRounding::Ratio1e9,
            pool: PoolRule::Round,
        }
    }
}

/// The variant options (and `contract.reward_weights`) set away from swarmfl's defaults, as
/// (key, value) pairs in key order.
pub fn changed_options(config: &Config) -> Vec<(String, String)> {
    let table = |o: &ContractOptions| toml::Table::try_from(o).expect("options encode as TOML");
    let (mine, default) = (
        table(&config.contract.options()),
        table(&ContractOptions::default()),
    );
    let mut changed: Vec<(String, String)> = mine
        .iter()
        .filter(|&(k, v)| default.get(k) != Some(v))
        .map(|(k, v)| (format!("contract.{k}"), v.to_string()))
        .collect();
    if !config.contract.reward_weights.is_empty() {
        changed.push((
            "contract.reward_weights".to_string(),
            format!("{:?}", config.contract.reward_weights),
        ));
    }
    changed.sort();
    changed
}

/// The variant options describe the paper's contract (`fedavg` and `paper`); the robust rules
/// would ignore them, so a configuration that sets one with a robust rule is refused rather
/// than silently run under other rules than it says.
pub fn check_rule_options(config: &Config) -> Result<(), ConfigError> {
    let rule = config.rule();
    if matches!(rule, Rule::Fedavg | Rule::Paper) {
        return Ok(());
    }
    match changed_options(config).into_iter().next() {
        None => Ok(()),
        Some((key, value)) => Err(ConfigError::OutOfRange {
            allowed: format!(
                "its default with contract.rule = {} (the authors' variant options apply to \
                 the paper's contract only: rules paper and fedavg); remove `{key}`, or set \
                 contract.rule = paper",
                rule.name()
            ),
            key,
            value,
        }),
    }
}

//! The contract's variants where swarmfl's rules and the authors' Solidity contract (geth-argos
//! `federatedsc3V2.sol`) differ; docs/CONTRACT.md has the table. The defaults are swarmfl's
//! rules; each option selects the authors' behaviour for one difference, in both engines.
//! The option types are defined in [`crate::config`]; here is what the contract makes of them.

use crate::config::{
    ContractOptions, FedAvgRounding, MedianRule, PayoutRounding, PoolRule, RankKey, RankOrder,
    RankTies, ThresholdRule,
};

impl ContractOptions {
    /// True for swarmfl's own rules (every option at its default).
    pub fn is_default(&self) -> bool {
        *self == ContractOptions::default()
    }

    /// The option bits of `contracts/SwarmFL.sol` (its `flags`). `rank_order` has none: the
    /// Solidity contract ranks around the median only, and validation refuses
    /// `contract.engine = "evm"` with another order.
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
            // Not one of the authors' variants: their contract ranks around the median too.
            rank_order: RankOrder::Median,
        }
    }
}

//! The base contract the contract's unit tests share; each test module changes the fields its
//! hand-computed rounds need (`ContractParams { .., ..test_support::params(..) }`).

use super::ContractParams;

/// One token in units (the paper's configuration: 10^9).
pub const TOKEN: u64 = 1_000_000_000;
/// The stake a submission carries: 5 tokens.
pub const STAKE: u64 = 5 * TOKEN;

/// `robots` accounts with 21 tokens each, a stake of 5 and the paper's rule with security on;
/// a round closes at `reward_weights.len()` accepted models; an all-zero genesis model of
/// `genesis_len` weights and an outlier threshold of 5 * 10^7 units per weight; no timeout,
/// robust rule, defence, pre-aggregator, buffer, plug-in or relative outlier rule.
pub fn params(robots: u32, reward_weights: Vec<i64>, genesis_len: usize) -> ContractParams {
    ContractParams {
        robots,
        initial_units: 21 * TOKEN,
        stake_units: STAKE,
        security: true,
        quorum: u32::try_from(reward_weights.len()).expect("a test's quorum fits u32"),
        outlier_threshold_units: 50_000_000,
        reward_weights,
        genesis_weights: vec![0i64; genesis_len].into(),
        robust: None,
        round_timeout_ms: 0,
        claim_bound: Default::default(),
        options: Default::default(),
        engine: Default::default(),
        defence: None,
        block_gas_limit: crate::config::AUTHORS_BLOCK_GAS_LIMIT,
        preagg: None,
        buffered: None,
        rule_plugin: None,
        outlier: None,
    }
}

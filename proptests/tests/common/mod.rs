//! What the contract property tests share: the token units and one base contract that each
//! test binary changes where its property needs it.

// Each test binary uses a part of this module.
#![allow(dead_code)]

use swarmfl_core::config::Rule;
use swarmfl_core::contract::{ContractParams, RobustRule};

/// One token in units.
pub const TOKEN: u64 = 1_000_000_000;
/// The stake a submission carries.
pub const STAKE: u64 = 5 * TOKEN;
/// The bound on a weight's magnitude (exclusive), 2^47.
pub const INT48: i64 = 1 << 47;

/// `robots` robots with 21 tokens each, a stake of 5 and the paper's rule with security on; a
/// round closes at `reward_weights.len()` submissions; a 3-weight genesis model (0, 10^6,
/// -10^6) and an outlier threshold of 5 * 10^7 units (a 3-weight model may be 1.5 * 10^8
/// units away from the shared one); no timeout, defence, pre-aggregator, buffer or plug-in.
pub fn base_params(robots: u32, reward_weights: Vec<i64>) -> ContractParams {
    ContractParams {
        robots,
        initial_units: 21 * TOKEN,
        stake_units: STAKE,
        security: true,
        quorum: reward_weights.len() as u32,
        outlier_threshold_units: 50_000_000,
        reward_weights,
        genesis_weights: vec![0i64, 1_000_000, -1_000_000].into(),
        robust: None,
        round_timeout_ms: 0,
        claim_bound: Default::default(),
        options: Default::default(),
        engine: Default::default(),
        defence: None,
        block_gas_limit: swarmfl_core::config::AUTHORS_BLOCK_GAS_LIMIT,
        preagg: None,
        buffered: None,
        rule_plugin: None,
        outlier: None,
    }
}

/// `rule` as the contract's robust rule with an assumed f of 1 (none for `fedavg` and `paper`,
/// which the contract runs without one).
pub fn robust(rule: Rule) -> Option<RobustRule> {
    match rule {
        Rule::Fedavg | Rule::Paper => None,
        rule => Some(RobustRule {
            rule,
            assumed_f: 1,
            threshold_gate: false,
        }),
    }
}

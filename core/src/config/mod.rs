//! The configuration: one serde tree holding every parameter of the system, with its default.
//!
//! Every number of docs/SPEC.md is a field here, documented where it is declared. A run is fully
//! determined by a [`Config`] and a seed. Configurations come from a named preset
//! ([`Preset`]), optionally overlaid with a TOML file and with `key.path=value` overrides
//! ([`Config::set`]); [`Config::validate`] then checks every range and names the offending key.
//!
//! A leaf of the crate: it imports only `types`, `rng` and `faults`. The types that the
//! configuration names (rules, defences, attacks, engines, options) are defined here, each
//! domain keeps their behaviour; the checks that span domains live in `validate.rs`.

// First: its macro is in scope in the modules below, which declare the plug points with it.
#[macro_use]
mod registry;

mod behaviour;
mod behaviour_fit;
mod byzantine;
mod contract;
mod error;
mod hints;
mod ledger;
mod overrides;
mod preagg;
mod preagg_fit;
mod preset;
mod protocol_fit;
mod ranges;
mod skip;
mod timing;
mod tree;
mod validate;

#[cfg(test)]
mod tests;

pub use behaviour::{
    Avoidance, Behaviour, FlockingConfig, ForagingConfig, ForagingRule, HomeRangeConfig,
    MixedAssign, MixedConfig, WindowRule, FLOWFL_LAYOUT_HALF_M, MIN_REGION_DIAMETERS,
    PLACE_LAYOUT_HALF_M,
};
pub use byzantine::{ByzantineKind, ByzantineVariant};
pub use contract::{
    mda_subsets, ContractEngine, ContractOptions, Defence, FedAvgRounding, GasEstimateState,
    GasLimitRule, MedianRule, OutlierRule, PayoutRounding, PoolRule, Quorum, RankKey, RankOrder,
    RankTies, RoundProtocol, Rule, ThresholdRule, MDA_MAX_SUBSETS,
};
// The plug points' file lists, for the domains that declare and dispatch them (`registry!`).
pub(crate) use byzantine::attack_files;
pub(crate) use contract::rule_files;
pub use error::ConfigError;
pub(crate) use ledger::ledger_attack_files;
pub use ledger::{LedgerBehaviour, WithholdPolicy};
pub use overrides::{is_reconfigurable, RECONFIGURABLE};
pub(crate) use preagg::preagg_files;
pub use preagg::{Preaggregator, StageOutputs, StageSpec};
pub use preset::{Preset, AUTHORS_CONTRACT};
pub(crate) use timing::timing_files;
pub use timing::{AuthorsTimingConfig, Timing};
pub use tree::{
    default_block_gas_limit, Aggregation, ByzantineConfig, Config, ContractConfig, DataConfig,
    Frame, LearnConfig, LedgerConfig, OutputConfig, RunConfig, WorldConfig,
    AUTHORS_BLOCK_GAS_LIMIT, DEFAULT_ROUND_TIMEOUT_S, GETH_RECOMMIT_S, WEB3_GAS_MARGIN,
};

/// Parses and validates a resolved configuration recorded as TOML text (a log header's or a
/// reconfiguration's); `source_name` names it in errors.
pub fn parse_config(text: &str, source_name: &str) -> Result<Config, ConfigError> {
    let config: Config = toml::from_str(text).map_err(|e| ConfigError::Parse {
        source_name: source_name.to_string(),
        message: e.to_string(),
    })?;
    config.validate()?;
    Ok(config)
}

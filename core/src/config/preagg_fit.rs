//! The checks that tie `contract.preaggregators` to the rest of the configuration: the rule,
//! the quorum, the engine and the aggregation (the stages themselves are in `preagg.rs`).

use super::contract::{ContractEngine, Rule};
use super::error::ConfigError;
use super::preagg::{Preaggregator, MAX_STAGES};
use super::ranges::out_of_range as refuse;
use super::tree::{Aggregation, Config};

/// The pre-aggregator chain fits the rest of the configuration: a staking rule on the chain's
/// native contract, at most [`MAX_STAGES`] stages, a bucket size of at least 1 (at most the quorum under
/// bucketing), a positive
/// radius, NNM and ARC given more models than `contract.assumed_f`, and the rule defined for
/// the number of models the chain leaves.
pub fn chain_fits(c: &Config) -> Result<(), ConfigError> {
    stage_parameters_fit(c)?;
    let stages = &c.contract.preaggregators;
    if stages.is_empty() {
        return Ok(());
    }
    let listed = format!(
        "[{}]",
        stages
            .iter()
            .map(|p| format!("\"{}\"", p.name()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    chain_has_a_place(c, &listed)?;
    enough_models_reach_the_rule(c, &listed)
}

/// The stages' own parameters: a bucket size in `[1, quorum]` under bucketing (at least 1
/// otherwise) and a clipping radius in `(0, 1e6]`, checked whether or not a chain is set.
fn stage_parameters_fit(c: &Config) -> Result<(), ConfigError> {
    let k = &c.contract;
    // The quorum bounds the bucket size only where bucketing runs: a swarm of 2 robots has a
    // quorum of 1, and the default size must not refuse it.
    let max_bucket = if k.preaggregators.contains(&Preaggregator::Bucketing) {
        c.quorum().max(1)
    } else {
        u32::MAX
    };
    if !(1..=max_bucket).contains(&k.bucket_size) {
        return refuse(
            "contract.bucket_size",
            k.bucket_size.to_string(),
            format!("an integer in [1, {max_bucket}] (at most the quorum with bucketing)"),
        );
    }
    if !(k.clip_radius.is_finite() && k.clip_radius > 0.0 && k.clip_radius <= 1.0e6) {
        return refuse(
            "contract.clip_radius",
            k.clip_radius.to_string(),
            "a number in (0, 1e6] (an update's L2 norm, in weight units)".to_string(),
        );
    }
    Ok(())
}

/// A non-empty chain (`listed`, as the message shows it) of at most [`MAX_STAGES`] stages,
/// in front of a staking rule on the chain's native contract.
fn chain_has_a_place(c: &Config, listed: &str) -> Result<(), ConfigError> {
    let k = &c.contract;
    if k.preaggregators.len() > MAX_STAGES {
        return refuse(
            "contract.preaggregators",
            listed.to_string(),
            format!("at most {MAX_STAGES} stages"),
        );
    }
    if !c.rule().stakes() {
        return refuse(
            "contract.preaggregators",
            listed.to_string(),
            "[] with rule fedavg (security off); pre-aggregators stand in front of a staking \
             rule: set contract.security = true, or contract.preaggregators = []"
                .to_string(),
        );
    }
    if k.engine == ContractEngine::Evm {
        return refuse(
            "contract.preaggregators",
            listed.to_string(),
            "[] with contract.engine = evm (the Solidity contract has no pre-aggregators); set \
             contract.engine = native"
                .to_string(),
        );
    }
    if c.learn.aggregation != Aggregation::Chain {
        return refuse(
            "contract.preaggregators",
            listed.to_string(),
            format!(
                "[] with learn.aggregation = {} (no contract); set learn.aggregation = chain",
                c.learn.aggregation.name()
            ),
        );
    }
    Ok(())
}

/// Following the quorum's models through the chain (`listed`, as the message shows it): NNM
/// and ARC each get more models than `contract.assumed_f`, and the rule gets at least as many
/// as it is defined for.
fn enough_models_reach_the_rule(c: &Config, listed: &str) -> Result<(), ConfigError> {
    let k = &c.contract;
    let (quorum, f) = (c.quorum(), k.assumed_f);
    let mut count = quorum;
    for (i, &stage) in k.preaggregators.iter().enumerate() {
        if stage.needs_more_than_f() && f >= count {
            return refuse(
                "contract.assumed_f",
                f.to_string(),
                format!(
                    "below {count}, the models reaching stage {i} ({}) of \
                     contract.preaggregators {listed}",
                    stage.name()
                ),
            );
        }
        count = stage.output_count(count, k.bucket_size);
    }
    let rule = c.rule();
    let needed = match rule {
        Rule::Paper => 1,
        rule => rule.min_quorum(f),
    };
    if count < needed {
        return refuse(
            "contract.preaggregators",
            listed.to_string(),
            format!(
                "a chain leaving at least {needed} models for rule {} with assumed_f {f}; this \
                 one leaves {count} of the quorum's {quorum} (raise contract.quorum_fraction or \
                 lower contract.bucket_size)",
                rule.name()
            ),
        );
    }
    Ok(())
}

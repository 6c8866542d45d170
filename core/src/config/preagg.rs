//! What `contract.preaggregators` names: the pre-aggregation stages composed in front of the
//! aggregation rule, and the checks that tie them to the rule, the quorum and the engine. How
//! each stage computes lives in `contract/preagg/`, one file each.

use serde::{Deserialize, Serialize};

use super::contract::{ContractEngine, Rule};
use super::error::ConfigError;
use super::tree::{Aggregation, Config};

/// The longest pre-aggregator chain a configuration may name: every stage costs at least one
/// pass over the round's models on every node, and no published chain is longer than two.
pub const MAX_STAGES: usize = 8;

/// One pre-aggregation stage (`contract.preaggregators`, applied in list order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preaggregator {
    /// Nearest-neighbour mixing: each model becomes the mean of its `n - f` nearest models.
    Nnm,
    /// Bucketing: a seeded shuffle, then the mean of each bucket of `contract.bucket_size`.
    Bucketing,
    /// Static clipping of each update to the radius `contract.clip_radius`.
    Clipping,
    /// Adaptive robust clipping: the largest updates are clipped to the norm of the next one.
    Arc,
}

impl Preaggregator {
    /// Every variant, in documentation order.
    pub const ALL: [Preaggregator; 4] = [
        Preaggregator::Nnm,
        Preaggregator::Bucketing,
        Preaggregator::Clipping,
        Preaggregator::Arc,
    ];

    /// The stage's name as written in configurations.
    pub fn name(self) -> &'static str {
        match self {
            Preaggregator::Nnm => "nnm",
            Preaggregator::Bucketing => "bucketing",
            Preaggregator::Clipping => "clipping",
            Preaggregator::Arc => "arc",
        }
    }

    /// Looks a stage up by its configuration name.
    pub fn from_name(name: &str) -> Option<Preaggregator> {
        Preaggregator::ALL.into_iter().find(|p| p.name() == name)
    }

    /// How many models leave the stage when `count` enter it: bucketing makes
    /// `ceil(count / bucket_size)` bucket means, every other stage one model per model.
    pub fn output_count(self, count: u32, bucket_size: u32) -> u32 {
        match self {
            Preaggregator::Bucketing => count.div_ceil(bucket_size.max(1)),
            Preaggregator::Nnm | Preaggregator::Clipping | Preaggregator::Arc => count,
        }
    }
}

/// The default bucket size, Karimireddy et al.'s `s = 2`.
pub fn default_bucket_size() -> u32 {
    2
}

/// The default static clipping radius (L2 norm of an update, in weight units).
pub fn default_clip_radius() -> f64 {
    1.0
}

/// True for the default bucket size: left out of the recorded configuration, so runs without
/// pre-aggregators keep their hashes.
pub fn is_default_bucket_size(s: &u32) -> bool {
    *s == default_bucket_size()
}

/// True for the default clipping radius (see [`is_default_bucket_size`]).
pub fn is_default_clip_radius(c: &f64) -> bool {
    *c == default_clip_radius()
}

fn refuse(key: &str, value: String, allowed: String) -> Result<(), ConfigError> {
    Err(ConfigError::OutOfRange {
        key: key.to_string(),
        value,
        allowed,
    })
}

/// The pre-aggregator chain fits the rest of the configuration: a staking rule on the chain's
/// native contract, at most [`MAX_STAGES`] stages, a bucket size of at least 1 (at most the quorum under
/// bucketing), a positive
/// radius, NNM and ARC given more models than `contract.assumed_f`, and the rule defined for
/// the number of models the chain leaves.
pub fn chain_fits(c: &Config) -> Result<(), ConfigError> {
    let k = &c.contract;
    let stages = &k.preaggregators;
    let (quorum, f) = (c.quorum(), k.assumed_f);
    // The quorum bounds the bucket size only where bucketing runs: a swarm of 2 robots has a
    // quorum of 1, and the default size must not refuse it.
    let max_bucket = if stages.contains(&Preaggregator::Bucketing) {
        quorum.max(1)
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
    if stages.len() > MAX_STAGES {
        return refuse(
            "contract.preaggregators",
            listed,
            format!("at most {MAX_STAGES} stages"),
        );
    }
    let rule = c.rule();
    if !rule.stakes() {
        return refuse(
            "contract.preaggregators",
            listed,
            "[] with rule fedavg (security off); pre-aggregators stand in front of a staking \
             rule: set contract.security = true, or contract.preaggregators = []"
                .to_string(),
        );
    }
    if k.engine == ContractEngine::Evm {
        return refuse(
            "contract.preaggregators",
            listed,
            "[] with contract.engine = evm (the Solidity contract has no pre-aggregators); set \
             contract.engine = native"
                .to_string(),
        );
    }
    if c.learn.aggregation != Aggregation::Chain {
        return refuse(
            "contract.preaggregators",
            listed,
            format!(
                "[] with learn.aggregation = {} (no contract); set learn.aggregation = chain",
                c.learn.aggregation.name()
            ),
        );
    }
    let mut count = quorum;
    for (i, &stage) in stages.iter().enumerate() {
        if matches!(stage, Preaggregator::Nnm | Preaggregator::Arc) && f >= count {
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
    let needed = match rule {
        Rule::Paper => 1,
        rule => rule.min_quorum(f),
    };
    if count < needed {
        return refuse(
            "contract.preaggregators",
            listed,
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

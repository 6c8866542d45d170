//! Pre-aggregators (`contract.preaggregators`): stages composed in front of the aggregation
//! rule, as ByzFL composes them in front of any aggregator. Each stage maps the round's models
//! to new models (one per model, or one per bucket), the next stage or the rule reads those.
//!
//! One file per stage, each with its formula and reference: [`nnm`], [`bucketing`],
//! [`clipping`], [`arc`], declared and dispatched by its line in the [`Preaggregator`]
//! registry (`config/preagg.rs`: `Nnm = "nnm" in nnm => ..`), which makes `declare_stages!`
//! (below) write `pub mod nnm;` and the arm that calls `nnm::Nnm`'s [`Stage`]: a new stage is
//! its file and its line. Every stage is integer arithmetic on the contract's fixed-point
//! weights with the rules' conventions (`rules/mod.rs`): squared distances exact in `u128`,
//! norms `floor(sqrt(.))`, means and scalings rounded half away from zero, ties to the earlier
//! model. The clipping stages clip *updates* `w_k - w(t)` around the shared model the round was
//! opened on (the contract receives models, not gradients; clipping a model's own norm would
//! shrink the shared model itself), NNM and bucketing average models, which is the same as
//! averaging updates up to the rounding.
//!
//! What the rule's output means for the rest of the contract ([`aggregate`]):
//! - The outlier check (the paper's threshold, at arrival) judges the submission as made: a
//!   stage runs only when the round closes.
//! - The new shared model is the rule's aggregate of the stages' output.
//! - The rewards stay on the submissions actually made: the rule's used set refers to stage
//!   outputs (a mixed model, a bucket), which no robot sent. With `paper` the used order is the
//!   paper's ranking of the raw submissions (as without stages); with every other rule it is the
//!   `k` raw submissions nearest (L1) to the aggregate, nearest first, where `k` is the number
//!   of stage outputs the rule used scaled back by the chain's shrink factor,
//!   `min(q, ceil(used * q / q_out))`. A Byzantine model that a stage mixed into an honest
//!   neighbourhood therefore earns nothing unless it is itself near the result.

use serde::{Deserialize, Serialize};

use super::payout;
use super::rules::{self, Aggregate, Input};
use crate::config::{ContractOptions, Preaggregator, Rule};
use crate::types::Digest;

/// Writes `pub mod file;` for each line of the [`Preaggregator`] registry and
/// `Preaggregator::implementation`, the `match` from each stage to the type of its name in its
/// file (`nnm::Nnm`). Every stage's line names its file: a line without one does not compile.
macro_rules! declare_stages {
    (Preaggregator: $( $Variant:ident in $file:ident ),+) => {
        $( pub mod $file; )+

        impl Preaggregator {
            /// The stage's arithmetic: the type its registry line names.
            fn implementation(self) -> &'static dyn Stage {
                match self {
                    $( Preaggregator::$Variant => &$file::$Variant, )+
                }
            }
        }
    };
}

crate::config::preagg_files!(declare_stages);

/// A pre-aggregation stage: the type of a stage's file (`nnm::Nnm`) that [`run_chain`] calls,
/// one call signature for every stage.
pub trait Stage {
    /// The models that leave the stage when `models` (non-empty, one length) enter it.
    fn apply(&self, models: &[Staged], stage: &StageInput) -> Vec<Staged>;
}

/// What a stage reads beside the models.
#[derive(Clone, Copy, Debug)]
pub struct StageInput<'a> {
    /// The chain's parameters (`assumed_f`, the bucket size, the clipping radius).
    pub params: &'a PreaggParams,
    /// The shared model the round was opened on.
    pub current: &'a [i64],
    /// The round's shuffle seed ([`shuffle_seed`]).
    pub seed: [u8; 32],
}

/// The pre-aggregator chain of a contract, fixed at genesis (see `ContractParams`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PreaggParams {
    /// The stages, applied in order (non-empty).
    pub stages: Vec<Preaggregator>,
    /// `f` of NNM and ARC: `contract.assumed_f`, also under `paper`, which ignores it.
    pub assumed_f: u32,
    /// Bucketing's `s`.
    pub bucket_size: u32,
    /// Static clipping's radius in fixed-point units (`round(clip_radius * weight_scale)`).
    pub clip_radius_units: u64,
}

impl PreaggParams {
    /// Checks what the stages rely on: a non-empty chain, a bucket size of at least 1, NNM and
    /// ARC given more models than `assumed_f`, and `rule` (with its own `f`) defined for the
    /// number of models the chain leaves of `quorum`.
    pub fn check(&self, rule: Rule, rule_f: u32, quorum: u32) -> Result<(), String> {
        if self.stages.is_empty() || self.bucket_size == 0 {
            return Err("a pre-aggregator chain needs stages and a bucket size >= 1".into());
        }
        let mut count = quorum;
        for stage in &self.stages {
            if stage.needs_more_than_f() && self.assumed_f >= count {
                return Err(format!(
                    "{} needs more than f = {} models, gets {count}",
                    stage.name(),
                    self.assumed_f
                ));
            }
            count = stage.output_count(count, self.bucket_size);
        }
        let needed = rule.min_quorum(rule_f);
        if count < needed {
            return Err(format!(
                "{} needs {needed} models, the pre-aggregators leave {count}",
                rule.name()
            ));
        }
        Ok(())
    }
}

/// A round's models flowing through the chain: the weights and the claimed samples that a
/// sample-weighted rule (`paper`) reads.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Staged {
    /// The model.
    pub weights: Vec<i64>,
    /// Samples: the submission's own, or a bucket's members' sum.
    pub samples: u64,
}

/// The seed of bucketing's shuffle: blake3 of the round number, the digest of the shared
/// model the round was opened on, and the senders and model digests of the round's accepted
/// submissions in chain order. Every node holds all of them when the round closes, so every
/// node shuffles alike; no wall clock and no node-local randomness enter. The last submitter
/// of a round could grind its model to pick its bucket (docs/CONTRACT.md).
pub fn shuffle_seed(round: u64, shared: &Digest, accepted: &[(u32, Digest)]) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(b"swarmfl bucketing v1");
    h.update(&round.to_le_bytes()).update(&shared.0);
    h.update(&(accepted.len() as u64).to_le_bytes());
    for (sender, digest) in accepted {
        h.update(&sender.to_le_bytes()).update(&digest.0);
    }
    *h.finalize().as_bytes()
}

/// Runs the chain on `inputs` (the round's accepted models in chain order) around `current`.
pub fn run_chain(
    params: &PreaggParams,
    current: &[i64],
    inputs: &[Input],
    seed: [u8; 32],
) -> Vec<Staged> {
    let mut models: Vec<Staged> = inputs
        .iter()
        .map(|s| Staged {
            weights: s.weights.to_vec(),
            samples: s.samples,
        })
        .collect();
    let input = StageInput {
        params,
        current,
        seed,
    };
    for stage in &params.stages {
        models = stage.implementation().apply(&models, &input);
    }
    models
}

/// A round's aggregate with the chain in front of `rule` (see the module doc for the used
/// set). `inputs` are the accepted submissions in chain order, `f` the rule's assumed count.
pub fn aggregate(
    rule: Rule,
    params: &PreaggParams,
    current: &[i64],
    inputs: &[Input],
    f: usize,
    options: &ContractOptions,
    seed: [u8; 32],
) -> Aggregate {
    let staged = run_chain(params, current, inputs, seed);
    let staged_inputs: Vec<Input> = staged
        .iter()
        .map(|s| Input {
            weights: &s.weights,
            samples: s.samples,
            distance_units: payout::distance_units(&s.weights, current),
        })
        .collect();
    let ruled = rule.aggregate(current, &staged_inputs, f, options);
    let used = if rule == Rule::Paper {
        rule.aggregate(current, inputs, f, options).used
    } else {
        let (q, q_out) = (inputs.len(), staged.len());
        let k = (ruled.used.len() * q).div_ceil(q_out).clamp(1, q);
        rules::nearest(inputs, &ruled.weights, k)
    };
    Aggregate {
        weights: ruled.weights,
        used,
    }
}

/// The mean of `models` (non-empty, one length), rounded half away from zero, with the sum of
/// their samples.
pub(crate) fn mean_of(models: &[&Staged]) -> Staged {
    let weights: Vec<&[i64]> = models.iter().map(|m| &m.weights[..]).collect();
    Staged {
        weights: rules::mean(&weights),
        samples: models.iter().map(|m| m.samples).sum(),
    }
}

/// `current + (w - current) * radius / norm` rounded half away from zero per coordinate when
/// the update's norm `floor(sqrt(|w - current|^2))` exceeds `radius`; `w` unchanged otherwise.
/// The product stays far inside `i128`: an update below 2^48, a radius below 2^60.
pub(crate) fn clip_to(weights: &[i64], current: &[i64], radius: u128) -> Vec<i64> {
    let norm = rules::isqrt(rules::squared_distance(weights, current));
    if norm <= radius {
        return weights.to_vec();
    }
    let (r, n) = (
        i128::try_from(radius).expect("a radius below 2^60"),
        i128::try_from(norm).expect("a norm below 2^57"),
    );
    weights
        .iter()
        .zip(current)
        .map(|(&w, &c)| {
            let x = i128::from(w) - i128::from(c);
            let step = payout::div_round_half_away(x * r, n);
            i64::try_from(i128::from(c) + step).expect("a clipped update between the models")
        })
        .collect()
}

/// Test stages: each model with one sample.
#[cfg(test)]
pub(crate) fn staged_of(models: &[&[i64]]) -> Vec<Staged> {
    models
        .iter()
        .map(|w| Staged {
            weights: w.to_vec(),
            samples: 1,
        })
        .collect()
}

#[cfg(test)]
mod tests;

//! What `contract.preaggregators` names: the pre-aggregation stages composed in front of the
//! aggregation rule, and their defaults. The checks that tie them to the rule, the quorum and
//! the engine are in `preagg_fit.rs` (they read the whole configuration, which holds these
//! types). How each stage computes lives in `contract/preagg/`, one file each.

use serde::{Deserialize, Serialize};

/// The longest pre-aggregator chain a configuration may name: every stage costs at least one
/// pass over the round's models on every node, and no published chain is longer than two.
pub const MAX_STAGES: usize = 8;

registry! {
    /// One pre-aggregation stage (`contract.preaggregators`, applied in list order): one line
    /// each, its name, its file in `contract/preagg/` (`in nnm`: `nnm.rs` and its type
    /// `nnm::Nnm`, declared and dispatched from the line by `contract::preagg::run_chain`) and
    /// what the checks need to know of it ([`StageSpec`]).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Preaggregator => StageSpec, files preagg_files {
        /// Nearest-neighbour mixing: each model becomes the mean of its `n - f` nearest models.
        Nnm = "nnm" in nnm
            => StageSpec { outputs: StageOutputs::PerModel, needs_more_than_f: true },
        /// Bucketing: a seeded shuffle, then the mean of each bucket of `contract.bucket_size`.
        Bucketing = "bucketing" in bucketing
            => StageSpec { outputs: StageOutputs::PerBucket, needs_more_than_f: false },
        /// Static clipping of each update to the radius `contract.clip_radius`.
        Clipping = "clipping" in clipping
            => StageSpec { outputs: StageOutputs::PerModel, needs_more_than_f: false },
        /// Adaptive robust clipping: the largest updates are clipped to the norm of the next one.
        Arc = "arc" in arc
            => StageSpec { outputs: StageOutputs::PerModel, needs_more_than_f: true },
    }
}

/// What a pre-aggregator's line in the registry says beside its name and file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StageSpec {
    /// How many models leave the stage.
    pub outputs: StageOutputs,
    /// True when the stage needs more models than `contract.assumed_f` (it keeps `n - f` of
    /// them, as NNM and ARC do).
    pub needs_more_than_f: bool,
}

/// How many models leave a stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageOutputs {
    /// One per model that enters.
    PerModel,
    /// One per bucket of `contract.bucket_size` models.
    PerBucket,
}

impl Preaggregator {
    /// How many models leave the stage when `count` enter it: bucketing makes
    /// `ceil(count / bucket_size)` bucket means, every other stage one model per model.
    pub fn output_count(self, count: u32, bucket_size: u32) -> u32 {
        match self.spec().outputs {
            StageOutputs::PerBucket => count.div_ceil(bucket_size.max(1)),
            StageOutputs::PerModel => count,
        }
    }

    /// True when the stage needs more models than the assumed Byzantine count (NNM, ARC).
    pub fn needs_more_than_f(self) -> bool {
        self.spec().needs_more_than_f
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
    super::skip::omit(*s == default_bucket_size())
}

/// True for the default clipping radius (see [`is_default_bucket_size`]).
pub fn is_default_clip_radius(c: &f64) -> bool {
    super::skip::omit(*c == default_clip_radius())
}

//! What `contract.preaggregators` names: the pre-aggregation stages composed in front of the
//! aggregation rule, and their defaults. The checks that tie them to the rule, the quorum and
//! the engine are in `preagg_fit.rs` (they read the whole configuration, which holds these
//! types). How each stage computes lives in `contract/preagg/`, one file each.

use serde::{Deserialize, Serialize};

/// The longest pre-aggregator chain a configuration may name: every stage costs at least one
/// pass over the round's models on every node, and no published chain is longer than two.
pub const MAX_STAGES: usize = 8;

registry! {
    /// One pre-aggregation stage (`contract.preaggregators`, applied in list order).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Preaggregator {
        /// Nearest-neighbour mixing: each model becomes the mean of its `n - f` nearest models.
        Nnm = "nnm",
        /// Bucketing: a seeded shuffle, then the mean of each bucket of `contract.bucket_size`.
        Bucketing = "bucketing",
        /// Static clipping of each update to the radius `contract.clip_radius`.
        Clipping = "clipping",
        /// Adaptive robust clipping: the largest updates are clipped to the norm of the next one.
        Arc = "arc",
    }
}

impl Preaggregator {
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
    super::skip::omit(*s == default_bucket_size())
}

/// True for the default clipping radius (see [`is_default_bucket_size`]).
pub fn is_default_clip_radius(c: &f64) -> bool {
    super::skip::omit(*c == default_clip_radius())
}

//! What `byzantine.kind` and `byzantine.variant` name: the attacks themselves live in
//! `byzantine/`, one file each.

use serde::{Deserialize, Serialize};

registry! {
    /// The behaviour of Byzantine robots (docs/SPEC.md section 5, and the attacks of
    /// `byzantine/`, each in the file its line names, `in alie`: `byzantine/alie.rs` and its
    /// type `alie::Alie`, declared and dispatched from the line by `byzantine::attack`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum ByzantineKind, files attack_files {
        /// No Byzantine robots (the count must be 0).
        None = "none",
        /// Uniformly random weights.
        Faulty = "faulty" in faulty,
        /// Resubmits the current shared model.
        Malicious = "malicious" in malicious,
        /// Follows the trend of the shared model to be ranked first.
        Smart = "smart" in smart,
        /// Reverses the last aggregation step.
        SignFlip = "sign-flip" in sign_flip,
        /// Gaussian noise on the shared model.
        Gaussian = "gaussian" in gaussian,
        /// A little is enough: the honest mean moved by a few honest standard deviations.
        Alie = "alie" in alie,
        /// Inner-product manipulation: the negated honest mean step.
        Ipm = "ipm" in ipm,
        /// Min-max: as far from the honest mean as the honest models are from each other.
        MinMax = "min-max" in min_max,
        /// Copies an honest model of the round (over-represents one robot's data).
        Mimic = "mimic" in mimic,
        /// A model just inside the outlier threshold, against the honest direction, with a huge
        /// claimed sample count.
        InflateSamples = "inflate-samples" in inflate_samples,
        /// Trains honestly on corrupted trajectories.
        PoisonData = "poison-data" in poison_data,
        /// The Byzantine robots agree on one model.
        Collude = "collude" in collude,
        /// `smart` until the Byzantine robots hold a token share, then `collude`.
        SmartThenCollude = "smart-then-collude" in smart_then_collude,
        /// `alie` with its factor line-searched against the contract's rule on the robot's chain.
        OptimalAlie = "optimal-alie" in optimal_alie,
        /// `ipm` with its factor line-searched against the contract's rule on the robot's chain.
        OptimalIpm = "optimal-ipm" in optimal_ipm,
        /// Extreme values: every weight at the edge of int48.
        ExtremeValue = "extreme-value" in extreme_value,
        /// Trains honestly on trajectories whose targets are mirrored across the heading.
        MirrorTargets = "mirror-targets" in mirror_targets,
        /// A plug-in attack named by `byzantine.plugin`, supplied by the program that runs the
        /// simulation (the Python package's `swarmfl.run(attack=...)`); the command cannot run it.
        Plugin = "plugin",
    }
}

/// Which formula a Byzantine behaviour follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ByzantineVariant {
    /// The paper's formulas.
    Paper,
    /// The reference implementation's variants (smart: positive-only noise, w(t) before the
    /// first change).
    Reference,
    /// The authors' code as it runs (`controllers/docker/fedlerv2.py`, `bad_behaviour`,
    /// rtype 2): smart adds `int(random() * mae * 2)`, i.e. 2 r Delta with `r` uniform in
    /// [0, 1) per weight, and its `previous` model is all zeros until the first aggregation,
    /// so its first submission extrapolates from zeros. Other attacks read it as `paper`.
    Authors,
}

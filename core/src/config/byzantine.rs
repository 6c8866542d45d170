//! What `byzantine.kind` and `byzantine.variant` name: the attacks themselves live in
//! `byzantine/`, one file each.

use serde::{Deserialize, Serialize};

/// The behaviour of Byzantine robots (docs/SPEC.md section 5, and the attacks of `byzantine/`,
/// each documented in its own file).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ByzantineKind {
    /// No Byzantine robots (the count must be 0).
    None,
    /// Uniformly random weights.
    Faulty,
    /// Resubmits the current shared model.
    Malicious,
    /// Follows the trend of the shared model to be ranked first.
    Smart,
    /// Reverses the last aggregation step.
    SignFlip,
    /// Gaussian noise on the shared model.
    Gaussian,
    /// A little is enough: the honest mean moved by a few honest standard deviations.
    Alie,
    /// Inner-product manipulation: the negated honest mean step.
    Ipm,
    /// Min-max: as far from the honest mean as the honest models are from each other.
    MinMax,
    /// Copies an honest model of the round (over-represents one robot's data).
    Mimic,
    /// A model just inside the outlier threshold, against the honest direction, with a huge
    /// claimed sample count.
    InflateSamples,
    /// Trains honestly on corrupted trajectories.
    PoisonData,
    /// The Byzantine robots agree on one model.
    Collude,
    /// `smart` until the Byzantine robots hold a token share, then `collude`.
    SmartThenCollude,
    /// `alie` with its factor line-searched against the contract's rule on the robot's chain.
    OptimalAlie,
    /// `ipm` with its factor line-searched against the contract's rule on the robot's chain.
    OptimalIpm,
    /// Extreme values: every weight at the edge of int48.
    ExtremeValue,
    /// Trains honestly on trajectories whose targets are mirrored across the heading.
    MirrorTargets,
    /// A plug-in attack named by `byzantine.plugin`, supplied by the program that runs the
    /// simulation (the Python package's `swarmfl.run(attack=...)`); the command cannot run it.
    Plugin,
}

impl ByzantineKind {
    /// Every variant, in documentation order.
    pub const ALL: [ByzantineKind; 19] = [
        ByzantineKind::None,
        ByzantineKind::Faulty,
        ByzantineKind::Malicious,
        ByzantineKind::Smart,
        ByzantineKind::SignFlip,
        ByzantineKind::Gaussian,
        ByzantineKind::Alie,
        ByzantineKind::Ipm,
        ByzantineKind::MinMax,
        ByzantineKind::Mimic,
        ByzantineKind::InflateSamples,
        ByzantineKind::PoisonData,
        ByzantineKind::Collude,
        ByzantineKind::SmartThenCollude,
        ByzantineKind::OptimalAlie,
        ByzantineKind::OptimalIpm,
        ByzantineKind::ExtremeValue,
        ByzantineKind::MirrorTargets,
        ByzantineKind::Plugin,
    ];

    /// The kind's name as written in configurations.
    pub fn name(self) -> &'static str {
        match self {
            ByzantineKind::None => "none",
            ByzantineKind::Faulty => "faulty",
            ByzantineKind::Malicious => "malicious",
            ByzantineKind::Smart => "smart",
            ByzantineKind::SignFlip => "sign-flip",
            ByzantineKind::Gaussian => "gaussian",
            ByzantineKind::Alie => "alie",
            ByzantineKind::Ipm => "ipm",
            ByzantineKind::MinMax => "min-max",
            ByzantineKind::Mimic => "mimic",
            ByzantineKind::InflateSamples => "inflate-samples",
            ByzantineKind::PoisonData => "poison-data",
            ByzantineKind::Collude => "collude",
            ByzantineKind::SmartThenCollude => "smart-then-collude",
            ByzantineKind::OptimalAlie => "optimal-alie",
            ByzantineKind::OptimalIpm => "optimal-ipm",
            ByzantineKind::ExtremeValue => "extreme-value",
            ByzantineKind::MirrorTargets => "mirror-targets",
            ByzantineKind::Plugin => "plugin",
        }
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
}

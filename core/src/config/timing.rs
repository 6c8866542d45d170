//! What `learn.timing` names: the timing model of the robots' learning schedule, one file per
//! model in `sim/timing/` (declared and dispatched from its line here), and the parameters of
//! the authors' timing (`learn.authors_timing`).

use serde::{Deserialize, Serialize};

registry! {
    /// When the robots' learning phases begin and when their submissions leave
    /// (`learn.timing`; docs/SPEC.md section 3, the schedule rows).
    #[derive(
        Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize,
    )]
    #[serde(rename_all = "lowercase")]
    pub enum Timing, files timing_files {
        /// Every robot, honest or Byzantine, on its own phase drawn uniformly in
        /// `[0, learn.training_period_s)` from the seed, start to start, its submission
        /// `learn.training_duration_s` after the phase begins (swarmfl's; the default).
        #[default]
        Independent = "independent" in independent,
        /// The authors' code (`controllers/docker/fedlerv2.py`, `tfserver/main.py`): every
        /// timer starts together; the Byzantine robots submit when theirs fires, in step within
        /// `learn.authors_timing.byzantine_jitter_s`; the honest robots' trainings queue at one
        /// first-come-first-served server that takes `learn.authors_timing.service_time_s`
        /// each, and an honest timer restarts when the training returns (end to start).
        Authors = "authors" in authors,
    }
}

/// The authors' timing's parameters (`learn.authors_timing`, read only under
/// `learn.timing = "authors"`; docs/SPEC.md derives the defaults).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AuthorsTimingConfig {
    /// The spread of the robots' timers around the shared one in each cycle, seconds: a
    /// robot's timer fires at the cycle's time plus a jitter drawn uniformly in `[0, this)`
    /// per robot and cycle (default 1 s: the authors' Byzantine robots submit "within about a
    /// second of each other", each polling its timer every 0.5 s and sending a transaction).
    /// At most `learn.training_period_s`.
    pub byzantine_jitter_s: f64,
    /// Seconds the one training server takes per honest training (default 1.5 s: the Keras
    /// timing of one training of the authors' model, `bench/keras_peer.py`, 1.19 s on 240
    /// training samples, scaled to the 289 of the about 361 samples a robot holds at the
    /// paper's 750 s expiration; docs/SPEC.md, "The authors' timing").
    pub service_time_s: f64,
}

impl Default for AuthorsTimingConfig {
    fn default() -> Self {
        AuthorsTimingConfig {
            byzantine_jitter_s: 1.0,
            service_time_s: 1.5,
        }
    }
}

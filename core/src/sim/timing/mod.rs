//! The timing models of the learning schedule (`learn.timing`): when each robot's learning
//! phases begin and when their submissions may leave. One file per model, each declared and
//! dispatched from its line of the registry (`config/timing.rs`); the driver asks the model of
//! its run for slots and never knows which one runs.
//!
//! A model is a pure function of the seed, the configuration and which robots are Byzantine:
//! it generates its slots lazily, on request, but the slots it gives do not depend on the
//! order of the requests (the look-ahead world asks ahead of the driver), so neither do the
//! records.

use crate::config::{Config, Timing};
use crate::types::RobotId;

/// One learning phase on the schedule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    /// When the phase begins: the robot reads the model at its own node's head and its data
    /// set, ms.
    pub begin_ms: u64,
    /// The earliest its submission leaves (its training's end), ms; at least `begin_ms`.
    pub ready_ms: u64,
}

/// What a timing model is built from.
pub struct Setup<'a> {
    /// The run's seed.
    pub seed: u64,
    /// The learning robots marked Byzantine (robots that only attack the ledger learn
    /// honestly and are not marked).
    pub byzantine: &'a [bool],
    /// `learn.training_period_s` in ms (at least 1).
    pub period_ms: u64,
    /// `learn.training_duration_s` in ms.
    pub duration_ms: u64,
    /// `learn.authors_timing.byzantine_jitter_s` in ms.
    pub jitter_ms: u64,
    /// `learn.authors_timing.service_time_s` in ms.
    pub service_ms: u64,
    /// At a fork's reconfiguration: each robot's next phase `(index, slot)` under the old
    /// model, which the new one keeps (the later ones follow the new settings). `None` at
    /// genesis.
    pub kept: Option<&'a [(u64, Slot)]>,
}

impl Setup<'_> {
    /// The durations of `config` in ms (a period of at least 1 ms).
    pub fn durations(config: &Config) -> (u64, u64, u64, u64) {
        let ms = |s: f64| (s * 1000.0).round() as u64;
        let l = &config.learn;
        (
            ms(l.training_period_s).max(1),
            ms(l.training_duration_s),
            ms(l.authors_timing.byzantine_jitter_s),
            ms(l.authors_timing.service_time_s),
        )
    }
}

/// A timing model: each robot's slots, phase by phase.
pub trait TimingModel: Send {
    /// `robot`'s slot in phase `phase` (0-based), generated if need be. A phase before one
    /// passed to [`TimingModel::forget`] is not asked for again.
    fn slot(&mut self, robot: RobotId, phase: u64) -> Slot;
    /// The driver has begun `robot`'s phases before `phase`: their slots may be dropped.
    fn forget(&mut self, robot: RobotId, phase: u64);
    /// Whether a robot submits even when its node holds its submission of the current round
    /// (the contract then refuses the second, `duplicate`, and the robot's turn is lost), as
    /// the authors' code does, instead of skipping the phase (`already-submitted`).
    fn submits_blind(&self) -> bool;
}

/// Declares the timing models' modules and [`model`] from the registry's lines.
macro_rules! declare_timings {
    (Timing: $( $Kind:ident in $file:ident ),+) => {
        $( pub mod $file; )+

        /// The timing model `timing` built from `setup`.
        pub fn model(timing: Timing, setup: &Setup) -> Box<dyn TimingModel> {
            match timing {
                $( Timing::$Kind => Box::new($file::$Kind::new(setup)), )+
            }
        }
    };
}

crate::config::timing_files!(declare_timings);

#[cfg(test)]
mod tests;

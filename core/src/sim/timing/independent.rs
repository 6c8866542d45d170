//! `independent` (swarmfl's schedule, the default): every robot, honest or Byzantine, on its
//! own phase drawn uniformly in `[0, learn.training_period_s)` from the seed
//! (`Purpose::Schedule`), start to start; a submission leaves `learn.training_duration_s`
//! after its phase begins. After a fork's reconfiguration the next phase is kept and the
//! later ones follow the new period.

use super::{Setup, Slot, TimingModel};
use crate::rng::{self, Purpose};
use crate::types::RobotId;

/// Each robot's phases: `anchor_ms + (phase - anchor_phase) * period_ms`.
pub struct Independent {
    /// Per robot: (a phase, when it begins).
    anchors: Vec<(u64, u64)>,
    period_ms: u64,
    duration_ms: u64,
}

impl Independent {
    /// The schedule of `setup`.
    pub fn new(setup: &Setup) -> Independent {
        let robots = setup.byzantine.len() as RobotId;
        let anchors = match setup.kept {
            Some(kept) => kept.iter().map(|&(phase, s)| (phase, s.begin_ms)).collect(),
            None => (0..robots)
                .map(|r| {
                    let phase0 = rng::stream(setup.seed, Purpose::Schedule, r).below(setup.period_ms);
                    (0, phase0)
                })
                .collect(),
        };
        Independent {
            anchors,
            period_ms: setup.period_ms,
            duration_ms: setup.duration_ms,
        }
    }
}

impl TimingModel for Independent {
    fn slot(&mut self, robot: RobotId, phase: u64) -> Slot {
        let (anchor_phase, anchor_ms) = self.anchors[robot as usize];
        debug_assert!(phase >= anchor_phase, "a phase before the kept one");
        let begin_ms = anchor_ms + (phase - anchor_phase) * self.period_ms;
        Slot {
            begin_ms,
            ready_ms: begin_ms + self.duration_ms,
        }
    }

    fn forget(&mut self, _robot: RobotId, _phase: u64) {}

    fn submits_blind(&self) -> bool {
        false
    }
}

//! The robots' learning loop on the driver side: each robot's schedule of learning phases, the
//! Byzantine robots' attack, and the decisions and submissions of phases under way.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::protocol::Submission;
use super::timing::{self, Setup, Slot, TimingModel};
use crate::byzantine::{self, plugin::Plugins};
use crate::config::{ByzantineKind, Config};
use crate::learn::{ModelShape, Spawned};
use crate::metrics::{LearnReport, SkipReason};
use crate::state::SimError;
use crate::types::RobotId;
use crate::world::heterogeneity::PositionTally;

/// A robot's decision for one learning phase, before its transaction is made.
pub(super) enum Plan {
    /// A training speculated from the same model: its outcome (waited for when the plans are
    /// carried out).
    Ready {
        spawned: Spawned,
        base_round: u64,
    },
    Train {
        job: usize,
        base_round: u64,
    },
    Forge {
        weights: Vec<f32>,
        samples: u32,
        base_round: u64,
    },
    /// A Byzantine robot's honest training on samples it chose (reported as forged).
    TrainForged {
        job: usize,
        base_round: u64,
    },
    Skip {
        reason: SkipReason,
        base_round: u64,
    },
}

/// A learning phase whose plan is decided.
pub(super) struct Decided {
    pub(super) robot: RobotId,
    /// The phase's index.
    pub(super) phase: u64,
    /// The earliest its submission leaves (the phase's start plus its training's duration
    /// on the schedule), ms.
    pub(super) ready_ms: u64,
    pub(super) plan: Plan,
}

/// A Byzantine robot's learning phase whose attack is waiting (see `byzantine::Action::Wait`).
#[derive(Clone, Copy)]
pub(super) struct Waiting {
    /// The phase's index (keys its random stream).
    pub(super) phase: u64,
    /// The earliest its submission leaves (the phase's start plus its training's duration on
    /// the schedule), ms.
    pub(super) ready_ms: u64,
}

/// A submission waiting for its training to finish (`learn.training_duration_s`).
pub(super) struct Pending {
    pub(super) report: LearnReport,
    pub(super) submission: Option<Submission>,
}

/// The robots' learning loop: schedule, training, forging, submitting (driver side).
pub(super) struct Learners {
    pub(super) shape: ModelShape,
    pub(super) byzantine: Vec<bool>,
    /// Robots that take no learning phase (`learn.withheld`).
    pub(super) withheld: Vec<bool>,
    /// The Byzantine robots' agent (`None` without Byzantine robots).
    pub(super) attack: Option<Arc<dyn byzantine::Attack>>,
    /// The plug-ins the run is offered (a fork's reconfiguration may name one).
    pub(super) plugins: Plugins,
    /// Byzantine robots whose attack chose to wait, by robot: the phase it waits in.
    pub(super) waiting: BTreeMap<RobotId, Waiting>,
    /// When each robot's next phase begins (its slot in `timing`), ms.
    pub(super) next_due_ms: Vec<u64>,
    /// Each robot's next phase.
    pub(super) phases: Vec<u64>,
    /// The schedule's timing model (`learn.timing`).
    pub(super) timing: Box<dyn TimingModel>,
    pub(super) stake_units: u64,
    /// By (submission time, robot, phase): a waited phase and the robot's next one may leave
    /// at the same time.
    pub(super) pending: BTreeMap<(u64, RobotId, u64), Pending>,
    /// Where the data of each phase lies (`world.position_heterogeneity`): counts only, read
    /// by no record.
    pub(super) positions: PositionTally,
}

impl Learners {
    /// The learning loop of `config`; an error when it names a plug-in `plugins` lacks.
    pub(super) fn new(config: &Config, seed: u64, plugins: &Plugins) -> Result<Learners, SimError> {
        let robots = config.world.robots;
        // Robots that only attack the ledger, and those blamed as if honest, train honestly.
        let byzantine = learning_byzantine(config, seed);
        let mut timing = timing_model(config, seed, &byzantine, None);
        Ok(Learners {
            shape: ModelShape::from_config(config),
            withheld: (0..robots)
                .map(|r| config.learn.withheld.contains(&r))
                .collect(),
            attack: byzantine::agent(&config.byzantine, plugins).map_err(SimError::Plugin)?,
            plugins: plugins.clone(),
            waiting: BTreeMap::new(),
            next_due_ms: (0..robots).map(|r| timing.slot(r, 0).begin_ms).collect(),
            phases: vec![0; robots as usize],
            byzantine,
            timing,
            stake_units: if config.rule().stakes() {
                config.contract.stake_tokens * config.contract.token_units
            } else {
                0
            },
            pending: BTreeMap::new(),
            positions: PositionTally::new(
                config.world.home_range.side().unwrap_or(3),
                config.world.arena_side_m,
                robots,
            ),
        })
    }

    /// `robot`'s slot in `phase` on the schedule.
    pub(super) fn slot(&mut self, robot: RobotId, phase: u64) -> Slot {
        self.timing.slot(robot, phase)
    }
}

/// The timing model of `config` for the learning robots marked in `byzantine`, keeping each
/// robot's next phase of `kept` (a fork's reconfiguration).
fn timing_model(
    config: &Config,
    seed: u64,
    byzantine: &[bool],
    kept: Option<&[(u64, Slot)]>,
) -> Box<dyn TimingModel> {
    let (period_ms, duration_ms, jitter_ms, service_ms) = Setup::durations(config);
    let setup = Setup {
        seed,
        byzantine,
        period_ms,
        duration_ms,
        jitter_ms,
        service_ms,
        kept,
    };
    timing::model(config.learn.timing, &setup)
}

impl Learners {
    /// Takes over a new configuration at a fork point: which robots are Byzantine, the
    /// schedule's period and duration from the next phase on, and the stake.
    /// (`Sim::forked` checked that the plug-ins each reconfiguration names are offered.)
    pub(super) fn reconfigure(&mut self, config: &Config, seed: u64) {
        let fresh = Learners::new(config, seed, &self.plugins)
            .expect("Sim::forked checked every reconfiguration's plug-in");
        // (The ledger agents keep the root configuration's behaviour: see `Sim::forked`.)
        self.byzantine = fresh.byzantine;
        self.withheld = fresh.withheld;
        self.attack = fresh.attack;
        // A phase waited under the old attack ends unsubmitted, without a report.
        self.waiting.clear();
        // Each robot's next phase keeps its slot; the later ones follow the new settings.
        let kept: Vec<(u64, Slot)> = (0..self.phases.len() as RobotId)
            .map(|r| {
                let phase = self.phases[r as usize];
                (phase, self.timing.slot(r, phase))
            })
            .collect();
        self.timing = timing_model(config, seed, &self.byzantine, Some(&kept));
        self.stake_units = fresh.stake_units;
    }
}

/// The robots whose learning phases the attack decides: the Byzantine robots of `config`
/// (none when only the ledger misbehaves) but those `byzantine.as_honest` names.
fn learning_byzantine(config: &Config, seed: u64) -> Vec<bool> {
    let robots = config.world.robots as usize;
    if config.byzantine.kind == ByzantineKind::None {
        return vec![false; robots];
    }
    let mut byzantine = byzantine::byzantine_robots(config, seed);
    for &r in &config.byzantine.as_honest {
        if let Some(b) = byzantine.get_mut(r as usize) {
            *b = false;
        }
    }
    byzantine
}

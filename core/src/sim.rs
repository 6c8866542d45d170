//! The driver: turns a seed and a configuration into the run's records, folding each event into
//! the reduced [`State`] as it goes.
//!
//! Two halves, kept apart on purpose:
//! - [`State`] ([`crate::state`]) is everything the reducers rebuild from events (the world,
//!   every node's ledger with its contract states, the robots' measurements): replaying a log
//!   re-creates it bit-exactly without any of the driver's agents.
//! - [`Sim`] owns the agents that *decide* events from the current state and their own random
//!   streams: the robots' controllers, the sealing and gossip scheduler ([`Network`]) and the
//!   learning loop (training, Byzantine forging, submitting). A decision becomes an [`Event`],
//!   the event is folded, then recorded.
//!
//! One tick of 0.1 s: the controllers' wheel commands (a `Tick` event) move the world to the
//! tick's end; the ledger events due until then follow (a checkpoint after every sealed block);
//! then every robot whose learning phase is due reads the shared model from its own chain,
//! trains on its current data set (or forges a model), and submits (a `Learn` report and a
//! `Submit` event). Trainings due in the same tick run in parallel and are combined in robot
//! order.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use crate::aggregation::{self, AggregationEvent, Gossiper};
use crate::byzantine::{self, ledger::LedgerAgents};
use crate::config::{Aggregation, ByzantineKind, Config};
use crate::contract::Call;
use crate::data::Sample;
use crate::event::{CheckpointCause, Event, Reconfiguration, Record};
use crate::faults::FaultSchedule;
use crate::learn::{self, ModelShape, Spawned, TrainData, TrainJob, TrainOutcome};
use crate::ledger::{LedgerEvent, Network, Tx};
use crate::metrics::{LearnAction, LearnReport, SkipReason};
use crate::rng::{self, Purpose};
use crate::state::{SimError, State};
use crate::types::{Digest, RobotId, SimTime};
use crate::world::{Controllers, TickEvent, World};

/// How far (simulated ms) the look-ahead world runs before the reduced state by default: the
/// window in which honest trainings are speculated in parallel. A performance knob only: the
/// records do not depend on it (a test runs with 0, with this and with a wider window).
/// Measured on the 2-core reference machine (`paper`, seed 1, trainings in the background):
/// 5 s, 10 s and 20 s give 17.7 s, 16.5 s and 16.4 s of wall time with 29.8 s, 28.5 s and
/// 29.7 s of CPU; 10 s wastes the fewest speculated trainings, which matters when two runs
/// share the cores (`sweep --jobs 2`). Speculating at every tick instead of only when a
/// training falls due: 16.5 s with 30.4 s of CPU, not kept.
pub const DEFAULT_LOOKAHEAD_MS: u64 = 10_000;

/// The parts of a run whose wall time a [`Profiler`] can attribute.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Part {
    /// Controllers, physics, sensing, data.
    World,
    /// Sealing, gossip, block validation and contract execution.
    Ledger,
    /// Local training and forging.
    Learning,
    /// State digests for checkpoints.
    Checkpoint,
    /// Writing the log (the caller's own work).
    Log,
}

/// Receives the driver's part switches; the command-line tool implements it with a clock.
/// (The core never reads the clock itself.)
pub trait Profiler: Send {
    /// From now on, time is spent in `part`.
    fn switch(&mut self, part: Part);
}

/// Parses and validates a resolved configuration recorded as TOML text (a log header's or a
/// reconfiguration's); `source_name` names it in errors.
pub fn parse_config(text: &str, source_name: &str) -> Result<Config, crate::config::ConfigError> {
    let config: Config = toml::from_str(text).map_err(|e| crate::config::ConfigError::Parse {
        source_name: source_name.to_string(),
        message: e.to_string(),
    })?;
    config.validate()?;
    Ok(config)
}

/// A robot's decision for one learning phase, before its transaction is made.
enum Plan {
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

/// A Byzantine robot's learning phase whose attack is waiting (see `byzantine::Action::Wait`).
#[derive(Clone, Copy)]
struct Waiting {
    /// The phase's index (keys its random stream).
    phase: u64,
    /// When the phase began: the submission leaves no earlier than this plus the training
    /// duration.
    started_ms: u64,
}

/// A submission waiting for its training to finish (`learn.training_duration_s`).
struct Pending {
    report: LearnReport,
    submission: Option<Submission>,
}

/// How a model is submitted: a transaction to the contract, or a baseline's write or upload.
enum Submission {
    Tx(Tx),
    Baseline(AggregationEvent),
}

/// What a robot starts a learning phase from, whatever the aggregation: the shared model at
/// its own chain's head, its stigmergy merge, or the server's model.
struct Start {
    weights: Arc<[i64]>,
    digest: Digest,
    round: u64,
}

impl From<aggregation::StartView> for Start {
    fn from(view: aggregation::StartView) -> Start {
        Start {
            weights: view.weights,
            digest: view.digest,
            round: view.round,
        }
    }
}

/// The robots' learning loop: schedule, training, forging, submitting (driver side).
struct Learners {
    shape: ModelShape,
    byzantine: Vec<bool>,
    /// The Byzantine robots' agent (`None` without Byzantine robots).
    attack: Option<Box<dyn byzantine::Attack>>,
    /// Byzantine robots whose attack chose to wait, by robot: the phase it waits in.
    waiting: BTreeMap<RobotId, Waiting>,
    next_due_ms: Vec<u64>,
    phases: Vec<u64>,
    period_ms: u64,
    duration_ms: u64,
    stake_units: u64,
    /// By (submission time, robot, phase): a waited phase and the robot's next one may leave
    /// at the same time.
    pending: BTreeMap<(u64, RobotId, u64), Pending>,
}

impl Learners {
    fn new(config: &Config, seed: u64) -> Learners {
        let period_ms = (config.learn.training_period_s * 1000.0).round().max(1.0) as u64;
        let robots = config.world.robots;
        Learners {
            shape: ModelShape::from_config(config),
            // Robots that only attack the ledger train honestly.
            byzantine: if config.byzantine.kind == ByzantineKind::None {
                vec![false; robots as usize]
            } else {
                byzantine::byzantine_robots(config, seed)
            },
            attack: byzantine::attack(config.byzantine.kind),
            waiting: BTreeMap::new(),
            next_due_ms: (0..robots)
                .map(|r| rng::stream(seed, Purpose::Schedule, r).below(period_ms))
                .collect(),
            phases: vec![0; robots as usize],
            period_ms,
            duration_ms: (config.learn.training_duration_s * 1000.0).round() as u64,
            stake_units: if config.rule().stakes() {
                config.contract.stake_tokens * config.contract.token_units
            } else {
                0
            },
            pending: BTreeMap::new(),
        }
    }
}

impl Learners {
    /// Takes over a new configuration at a fork point: which robots are Byzantine, the
    /// schedule's period and duration from the next phase on, and the stake.
    fn reconfigure(&mut self, config: &Config, seed: u64) {
        let fresh = Learners::new(config, seed);
        // (The ledger agents keep the root configuration's behaviour: see `Sim::forked`.)
        self.byzantine = fresh.byzantine;
        self.attack = fresh.attack;
        // A phase waited under the old attack ends unsubmitted, without a report.
        self.waiting.clear();
        self.period_ms = fresh.period_ms;
        self.duration_ms = fresh.duration_ms;
        self.stake_units = fresh.stake_units;
    }
}

/// A copy of the world that runs ahead of the reduced state. The world does not depend on the
/// ledger or on learning, so the controllers decide on the copy; their tick events wait in a
/// queue for the reduced state, and the copy captures the data set of every honest learning
/// phase when it falls due. Those data sets (exactly the ones the reduced world holds then)
/// let the driver train several robots at once, speculatively, from the shared model each one
/// sees now; a speculated result is used only if the robot's model is still the same when its
/// phase comes. The speculated trainings run on rayon's pool in the background
/// ([`Spawned`]) while the driver goes on; the driver waits for one only when its robot's
/// phase comes. Trainings are pure functions of (model, data, seed, robot, phase), so the
/// records cannot depend on the window or on when the pool computes them.
struct LookAhead {
    world: World,
    controllers: Controllers,
    ticks: VecDeque<TickEvent>,
    next_tick: u64,
    window_ticks: u64,
    next_due_ms: Vec<u64>,
    phases: Vec<u64>,
    /// Data sets of upcoming honest phases, by (due time, robot): (phase, samples).
    upcoming: BTreeMap<(u64, RobotId), (u64, Vec<Sample>)>,
    /// Speculated trainings by (robot, phase): (digest of the start model, the training,
    /// running on rayon's pool or done). Dropping one that has not started cancels it.
    speculated: BTreeMap<(RobotId, u64), (Digest, Spawned)>,
}

/// The driver of one run: an iterator over its records.
pub struct Sim {
    config: Config,
    seed: u64,
    state: State,
    network: Network,
    /// The stigmergy's gossip scheduler (`learn.aggregation = "gossip"`; idle otherwise).
    gossiper: Gossiper,
    ahead: LookAhead,
    learners: Learners,
    tick_ms: u64,
    total_ticks: u64,
    next_tick: u64,
    queue: VecDeque<Record>,
    genesis_checked: bool,
    finished: bool,
    profiler: Option<Box<dyn Profiler>>,
    /// Reconfigurations still to come, in time order, with their parsed configurations.
    reconfigurations: VecDeque<(Reconfiguration, Config)>,
    /// The faults of the run (driver side).
    faults: FaultSchedule,
    /// The Byzantine robots' ledger misbehaviour.
    agents: LedgerAgents,
}

impl Sim {
    /// A run of `config` seeded with `seed`, at time 0.
    pub fn new(config: Config, seed: u64) -> Result<Sim, SimError> {
        Sim::with_lookahead(config, seed, DEFAULT_LOOKAHEAD_MS)
    }

    /// A run whose speculative training window is `lookahead_ms` (0: each robot trains when
    /// due, alone). The records are the same for every window.
    pub fn with_lookahead(config: Config, seed: u64, lookahead_ms: u64) -> Result<Sim, SimError> {
        let state = State::genesis(&config, seed)?;
        let tick_ms = (config.run.tick_s * 1000.0).round() as u64;
        assert!(tick_ms > 0, "validated config has tick_s >= 1 ms");
        let learners = Learners::new(&config, seed);
        let ahead = LookAhead {
            world: state.world.clone(),
            controllers: Controllers::new(&config, seed),
            ticks: VecDeque::new(),
            next_tick: 0,
            window_ticks: lookahead_ms.div_ceil(tick_ms),
            next_due_ms: learners.next_due_ms.clone(),
            phases: vec![0; config.world.robots as usize],
            upcoming: BTreeMap::new(),
            speculated: BTreeMap::new(),
        };
        let agents = LedgerAgents::new(&config, seed);
        let mut network = Network::new(&config, seed);
        network.set_withhold(agents.withhold_policy());
        Ok(Sim {
            total_ticks: config.ticks(),
            network,
            gossiper: Gossiper::new(&config, seed),
            faults: FaultSchedule::new(&config.faults, config.world.robots),
            agents,
            ahead,
            learners,
            config,
            seed,
            state,
            tick_ms,
            next_tick: 0,
            queue: VecDeque::new(),
            genesis_checked: false,
            finished: false,
            profiler: None,
            reconfigurations: VecDeque::new(),
        })
    }

    /// A forked run: `config` seeded with `seed` from time 0, taking over each reconfiguration's
    /// configuration at the end of its tick (oldest first). Each may change only the keys that
    /// may change mid-run ([`crate::config::RECONFIGURABLE`]) and must come before the end of
    /// the run it changes.
    pub fn forked(
        config: Config,
        seed: u64,
        reconfigurations: &[Reconfiguration],
    ) -> Result<Sim, SimError> {
        let mut sim = Sim::new(config, seed)?;
        let mut current = sim.config.clone();
        let mut last_ms = 0;
        for (index, change) in reconfigurations.iter().enumerate() {
            let fail = |message: String| SimError::Reconfiguration {
                index,
                at_ms: change.at_ms,
                message,
            };
            if change.at_ms == 0 || change.at_ms % sim.tick_ms != 0 {
                return Err(fail(format!(
                    "must be at the end of a tick (a positive multiple of {} ms)",
                    sim.tick_ms
                )));
            }
            if change.at_ms < last_ms {
                return Err(fail(format!(
                    "comes before the previous one at {last_ms} ms"
                )));
            }
            if change.at_ms >= current.ticks() * sim.tick_ms {
                return Err(fail(format!(
                    "the run it changes ends at {} ms",
                    current.ticks() * sim.tick_ms
                )));
            }
            let next = parse_config(&change.config_toml, "the reconfiguration")
                .map_err(|e| fail(e.to_string()))?;
            current
                .check_reconfiguration(&next)
                .map_err(|e| fail(e.to_string()))?;
            if next.ticks() * sim.tick_ms <= change.at_ms {
                return Err(fail(format!(
                    "run.duration_s = {} ends the run before the fork point",
                    next.run.duration_s
                )));
            }
            last_ms = change.at_ms;
            sim.reconfigurations
                .push_back((change.clone(), next.clone()));
            current = next;
        }
        Ok(sim)
    }

    /// Attributes the driver's time to its parts.
    pub fn set_profiler(&mut self, profiler: Box<dyn Profiler>) {
        self.profiler = Some(profiler);
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The current reduced state.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// Simulated time reached and total, in milliseconds.
    pub fn progress(&self) -> (u64, u64) {
        (
            self.next_tick * self.tick_ms,
            self.total_ticks * self.tick_ms,
        )
    }

    fn switch(&mut self, part: Part) {
        if let Some(p) = self.profiler.as_mut() {
            p.switch(part);
        }
    }

    fn emit(&mut self, time: SimTime, event: Event) {
        self.state
            .apply(time, &event)
            .unwrap_or_else(|e| panic!("the driver produced an event its own state rejects: {e}"));
        self.queue.push_back(Record::Event { time, event });
    }

    fn checkpoint(&mut self, time: SimTime, cause: CheckpointCause) {
        self.switch(Part::Checkpoint);
        let c = self.state.checkpoint(time, cause);
        self.queue.push_back(Record::Checkpoint(c));
    }

    /// Decides, folds and queues the records of the next tick.
    fn advance(&mut self) {
        if !self.genesis_checked {
            self.genesis_checked = true;
            self.checkpoint(SimTime(0), CheckpointCause::Genesis);
            return;
        }
        if self.next_tick == self.total_ticks {
            let end = self.state.world.time();
            self.checkpoint(end, CheckpointCause::End);
            self.finished = true;
            return;
        }
        let time = SimTime(self.next_tick * self.tick_ms);
        self.switch(Part::World);
        self.run_ahead();
        let tick = self
            .ahead
            .ticks
            .pop_front()
            .expect("the look-ahead world is ahead");
        self.emit(time, Event::Tick(tick));
        self.next_tick += 1;
        let now = SimTime(self.next_tick * self.tick_ms);
        debug_assert_eq!(now, self.state.world.time());

        self.switch(Part::Ledger);
        let peers = self.peers(now);
        match self.config.learn.aggregation {
            Aggregation::Chain => self.ledger_tick(time, now, &peers),
            Aggregation::Gossip => {
                while let Some((at, event)) =
                    self.gossiper
                        .next_event(&self.state.aggregation.stigmergy, now, &peers)
                {
                    self.emit(at, Event::Aggregation(event));
                }
            }
            // The ideal server is not on the radio: uploads and downloads are instant.
            Aggregation::Central => {}
        }
        if self.config.learn.aggregation != Aggregation::Chain
            && now.0.is_multiple_of(self.period_checkpoint_ms())
        {
            // No blocks: a checkpoint every block period pins the state for replay, inspect
            // and bisect by time.
            self.checkpoint(now, CheckpointCause::Periodic);
        }

        self.switch(Part::Learning);
        self.learning_phase(now);
        self.release_submissions(now);
        while self
            .reconfigurations
            .front()
            .is_some_and(|(change, _)| change.at_ms == now.0)
        {
            let (change, config) = self.reconfigurations.pop_front().expect("checked");
            self.reconfigure(now, change, config);
        }
    }

    /// The ledger's part of the tick from `time` to `now`: restarts of crashed nodes, the
    /// sealings, gossip and deliveries due, the Byzantine nodes' injections.
    fn ledger_tick(&mut self, time: SimTime, now: SimTime, peers: &[Vec<RobotId>]) {
        for (restart_ms, robot) in self.faults.restart_times(time.0, now.0) {
            self.ledger_until(SimTime(restart_ms - 1), peers);
            self.network.on_restart(robot);
            self.emit(
                SimTime(restart_ms),
                Event::Ledger(LedgerEvent::Restart { node: robot }),
            );
        }
        self.ledger_until(now, peers);
        let faults = &self.faults;
        let injections = self.agents.on_tick(&self.state.ledger, now, peers, &|r| {
            faults.is_down(r, now.0)
        });
        for event in injections {
            self.emit(now, Event::Ledger(event));
        }
    }

    /// The checkpoint period of a run without blocks: the block period, in ms.
    fn period_checkpoint_ms(&self) -> u64 {
        ((self.config.ledger.block_period_s * 1000.0).round() as u64).max(1)
    }

    /// The radio's peer sets at `now` with the links the faults cut removed.
    fn peers(&self, now: SimTime) -> Vec<Vec<RobotId>> {
        let robots = self.config.world.robots;
        let mut peers: Vec<Vec<RobotId>> = (0..robots)
            .map(|r| self.state.world.peers(r).to_vec())
            .collect();
        if self.faults.cuts_links() {
            let x: Vec<f64> = self.state.world.poses().iter().map(|p| p.x).collect();
            let top = (0..robots)
                .map(|r| self.state.ledger.head(r).1)
                .max()
                .unwrap_or(0);
            let in_turn = ((top + 1) % u64::from(robots)) as RobotId;
            self.faults.filter_peers(&mut peers, now.0, &x, in_turn);
        }
        peers
    }

    /// Applies the ledger events due until `until`: a checkpoint after each sealing, and the
    /// sealer's misbehaviour right after it, if it is Byzantine on the ledger.
    fn ledger_until(&mut self, until: SimTime, peers: &[Vec<RobotId>]) {
        while let Some((at, event)) = self.network.next_event(&self.state.ledger, until, peers) {
            let sealed = match &event {
                LedgerEvent::Seal { node, .. } => Some(*node),
                _ => None,
            };
            self.emit(at, Event::Ledger(event));
            if let Some(node) = sealed {
                let (head, height) = self.state.ledger.head(node);
                self.checkpoint(at, CheckpointCause::Block { node, height });
                self.switch(Part::Ledger);
                let injections = self
                    .agents
                    .after_seal(&self.state.ledger, node, head, at, peers);
                for event in injections {
                    self.emit(at, Event::Ledger(event));
                }
            }
        }
    }

    /// Takes over `config` at the end of the tick ending at `now`: the event (the contract's
    /// rules for later blocks), the agents' new settings, a fresh speculation window (the
    /// trainings speculated under the old settings are dropped) and a checkpoint.
    fn reconfigure(&mut self, now: SimTime, change: Reconfiguration, config: Config) {
        self.emit(now, Event::Reconfigure(change));
        self.learners.reconfigure(&config, self.seed);
        let a = &mut self.ahead;
        a.speculated.clear();
        a.upcoming.clear();
        a.next_due_ms.clone_from(&self.learners.next_due_ms);
        a.phases.clone_from(&self.learners.phases);
        // Phases the look-ahead world has already passed are not captured: they read the
        // reduced world's data set when due.
        let ahead_ms = a.next_tick * self.tick_ms;
        for (due, phase) in a.next_due_ms.iter_mut().zip(a.phases.iter_mut()) {
            while *due <= ahead_ms {
                *due += self.learners.period_ms;
                *phase += 1;
            }
        }
        self.total_ticks = config.ticks();
        self.config = config;
        self.checkpoint(now, CheckpointCause::Reconfigure);
    }

    /// Advances the look-ahead world to the window's end (at least one tick past the state).
    fn run_ahead(&mut self) {
        let until = (self.next_tick + 1 + self.ahead.window_ticks).min(self.total_ticks);
        while self.ahead.next_tick < until {
            let a = &mut self.ahead;
            let tick = a.controllers.decide(&a.world);
            a.world.apply(&tick);
            a.ticks.push_back(tick);
            a.next_tick += 1;
            let now_ms = a.next_tick * self.tick_ms;
            for r in 0..self.config.world.robots {
                let i = r as usize;
                while a.next_due_ms[i] <= now_ms {
                    if !self.learners.byzantine[i] {
                        a.upcoming
                            .insert((a.next_due_ms[i], r), (a.phases[i], a.world.dataset(r)));
                    }
                    a.phases[i] += 1;
                    a.next_due_ms[i] += self.learners.period_ms;
                }
            }
        }
    }

    /// Every robot whose learning phase is due by `now` trains (on the pool, beside the
    /// window's speculated trainings, which this starts and leaves running) or, if Byzantine,
    /// asks its attack; waiting attacks are asked again. Queues the submissions.
    fn learning_phase(&mut self, now: SimTime) {
        // Byzantine robots waiting in an earlier phase are asked again first (robot order);
        // one whose next phase is due now has its last chance.
        let waiting: Vec<(RobotId, Waiting)> = self
            .learners
            .waiting
            .iter()
            .map(|(&r, &w)| (r, w))
            .collect();
        let due: Vec<RobotId> = (0..self.config.world.robots)
            .filter(|&r| self.learners.next_due_ms[r as usize] <= now.0)
            .collect();
        if due.is_empty() && waiting.is_empty() {
            return;
        }
        let mut jobs = Vec::new();
        let mut plans = Vec::with_capacity(due.len() + waiting.len());
        for (r, w) in waiting {
            self.learners.waiting.remove(&r);
            let last_chance = self.learners.next_due_ms[r as usize] <= now.0;
            match self.byzantine_plan(r, w, now, last_chance, &mut jobs) {
                Some(plan) => plans.push((r, w.phase, w.started_ms, plan)),
                None if last_chance => {
                    let base_round = self.current(r).round;
                    let report = LearnReport {
                        robot: r,
                        base_round,
                        action: LearnAction::Skipped {
                            reason: SkipReason::Waited,
                        },
                    };
                    self.emit(now, Event::Learn(report));
                }
                None => {
                    self.learners.waiting.insert(r, w);
                }
            }
        }
        for &r in &due {
            let i = r as usize;
            let phase = self.learners.phases[i];
            let due_ms = self.learners.next_due_ms[i];
            self.learners.phases[i] += 1;
            self.learners.next_due_ms[i] += self.learners.period_ms;
            let captured = self.ahead.upcoming.remove(&(due_ms, r));
            let speculated = self.ahead.speculated.remove(&(r, phase));
            if self.config.learn.aggregation != Aggregation::Chain {
                // A baseline robot merges its replica (gossip) or downloads the server's model
                // (central) as its phase begins, Byzantine or not: that is an event.
                self.emit(
                    now,
                    Event::Aggregation(AggregationEvent::Merge { robot: r }),
                );
            }
            if self.learners.byzantine[i] {
                let w = Waiting {
                    phase,
                    started_ms: now.0,
                };
                match self.byzantine_plan(r, w, now, false, &mut jobs) {
                    Some(plan) => plans.push((r, phase, now.0, plan)),
                    None => {
                        self.learners.waiting.insert(r, w);
                    }
                }
                continue;
            }
            let view = self.current(r);
            let base_round = view.round;
            let plan = if let Some(reason) = self.cannot_submit(r, now) {
                Plan::Skip { reason, base_round }
            } else {
                let samples = match captured {
                    Some((captured_phase, samples)) => {
                        debug_assert_eq!(captured_phase, phase);
                        debug_assert!(
                            samples == self.state.world.dataset(r),
                            "the look-ahead world diverged"
                        );
                        samples
                    }
                    None => self.state.world.dataset(r),
                };
                let data = TrainData::new(&self.learners.shape, &samples).ok();
                let trainable = self.trainable(samples.len());
                match (data, speculated) {
                    (Some(_), Some((digest, spawned))) if trainable && digest == view.digest => {
                        Plan::Ready {
                            spawned,
                            base_round,
                        }
                    }
                    (Some(data), _) if trainable => {
                        jobs.push(self.train_job(r, phase, &view.weights, data));
                        Plan::Train {
                            job: jobs.len() - 1,
                            base_round,
                        }
                    }
                    _ => Plan::Skip {
                        reason: SkipReason::NotEnoughData,
                        base_round,
                    },
                }
            };
            plans.push((r, phase, now.0, plan));
        }
        // The due trainings go to the pool first, then the window's speculated ones; this
        // thread takes any due one no pool thread has started, and waits for the others.
        let due_jobs: Vec<Spawned> = jobs.into_iter().map(Spawned::start).collect();
        if !due_jobs.is_empty() {
            self.speculate(now);
        }
        let outcomes: Vec<TrainOutcome> = due_jobs.into_iter().map(Spawned::wait).collect();
        for (r, phase, started_ms, plan) in plans {
            // A phase's submission leaves a training duration after the phase began, or now
            // if a waiting attack decided later than that.
            let submit_at = (started_ms + self.learners.duration_ms).max(now.0);
            let (base_round, action, submission) = match plan {
                Plan::Skip { reason, base_round } => {
                    (base_round, LearnAction::Skipped { reason }, None)
                }
                Plan::Forge {
                    weights,
                    samples: claimed,
                    base_round,
                } => {
                    let (action, tx) = self.forged(r, &weights, claimed);
                    (base_round, action, tx)
                }
                Plan::Train { job, base_round } => {
                    let (action, tx) = self.trained(r, &outcomes[job]);
                    (base_round, action, tx)
                }
                Plan::TrainForged { job, base_round } => {
                    let outcome = &outcomes[job];
                    let (action, tx) = self.forged(r, &outcome.weights, outcome.train_samples);
                    (base_round, action, tx)
                }
                Plan::Ready {
                    spawned,
                    base_round,
                } => {
                    let (action, tx) = self.trained(r, &spawned.wait());
                    (base_round, action, tx)
                }
            };
            let report = LearnReport {
                robot: r,
                base_round,
                action,
            };
            self.learners
                .pending
                .insert((submit_at, r, phase), Pending { report, submission });
        }
    }

    /// Why `robot` cannot submit now, in its own node's view: it is down, its balance is below
    /// the stake (when the rule stakes), or it already submitted in the current round.
    fn cannot_submit(&self, robot: RobotId, now: SimTime) -> Option<SkipReason> {
        if self.faults.is_down(robot, now.0) {
            Some(SkipReason::Crashed)
        } else if self.config.learn.aggregation == Aggregation::Chain
            && self.config.rule().stakes()
            && self.state.ledger.head_state(robot).balances[robot as usize]
                < self.learners.stake_units
        {
            Some(SkipReason::InsufficientStake)
        } else if self.submitted(robot) {
            Some(SkipReason::AlreadySubmitted)
        } else {
            None
        }
    }

    /// Whether a data set of `samples` samples leaves enough for training after the
    /// validation split (`learn.min_train_samples`, at least 1).
    fn trainable(&self, samples: usize) -> bool {
        let min_train = self.config.learn.min_train_samples.max(1) as usize;
        learn::split_point(samples, self.config.learn.train_fraction) >= min_train
    }

    /// `robot`'s training in `phase` from the on-chain (fixed-point) `weights`, with its own
    /// dropout stream.
    fn train_job(&self, robot: RobotId, phase: u64, weights: &[i64], data: TrainData) -> TrainJob {
        TrainJob {
            shape: self.learners.shape.clone(),
            cfg: self.config.learn.clone(),
            start: learn::from_fixed(weights, self.config.contract.weight_scale),
            data,
            dropout: rng::substream(self.seed, Purpose::Dropout, robot, phase),
        }
    }

    /// Whether `robot`'s model already waits in the open round: on its own chain, or at the
    /// server. A stigmergy write never waits (each phase overwrites the robot's key).
    fn submitted(&self, robot: RobotId) -> bool {
        match self.config.learn.aggregation {
            Aggregation::Chain => self.state.ledger.head_state(robot).has_submitted(robot),
            Aggregation::Gossip => false,
            Aggregation::Central => self.state.aggregation.server.has_pending(robot),
        }
    }

    /// What `robot` starts from now: the shared model at its own chain's head, its model after
    /// its last merge (`gossip`), or the server's model (`central`).
    fn current(&self, robot: RobotId) -> Start {
        match self.config.learn.aggregation {
            Aggregation::Chain => {
                let head = self.state.ledger.head_state(robot);
                Start {
                    weights: head.weights.clone(),
                    digest: head.weights_digest,
                    round: head.round,
                }
            }
            _ => Start::from(self.state.aggregation.current(robot)),
        }
    }

    /// What `robot` would start from if its phase began now (for speculative training): as
    /// [`Sim::current`], except that a `gossip` robot would merge its replica as it is now.
    fn preview(&self, robot: RobotId) -> Start {
        match self.config.learn.aggregation {
            Aggregation::Chain => self.current(robot),
            _ => Start::from(self.state.aggregation.preview(robot)),
        }
    }

    /// Asks the Byzantine `robot`'s attack what to do in phase `w` now; `None` when it waits.
    /// A training it asks for is added to `jobs`.
    fn byzantine_plan(
        &self,
        robot: RobotId,
        w: Waiting,
        now: SimTime,
        last_chance: bool,
        jobs: &mut Vec<TrainJob>,
    ) -> Option<Plan> {
        // Without a chain, the attack reads the same kind of view built from what the robot
        // holds: its stigmergy replica, or the server (`AggregationState::attacker_view`).
        let baseline;
        let chain = match self.config.learn.aggregation {
            Aggregation::Chain => self.state.ledger.head_state(robot),
            Aggregation::Gossip | Aggregation::Central => {
                baseline = self
                    .state
                    .aggregation
                    .attacker_view(robot, self.state.ledger.current_params());
                &baseline
            }
        };
        let base_round = chain.round;
        if let Some(reason) = self.cannot_submit(robot, now) {
            return Some(Plan::Skip { reason, base_round });
        }
        let attack = self
            .learners
            .attack
            .as_ref()
            .expect("Byzantine robots have an attack (validated: count > 0 needs a kind)");
        let view = byzantine::View {
            robot,
            now_ms: now.0,
            last_chance,
            chain,
            params: self.state.ledger.current_params(),
            weight_scale: self.config.contract.weight_scale,
            coalition: &self.learners.byzantine,
            world: &self.state.world,
            config: &self.config.byzantine,
            input_waypoints: self.config.data.input_waypoints as usize,
        };
        let mut rng = rng::substream(self.seed, Purpose::Byzantine, robot, w.phase);
        Some(match attack.act(&view, &mut rng) {
            byzantine::Action::Wait => return None,
            byzantine::Action::Submit { weights, samples } => Plan::Forge {
                weights,
                samples,
                base_round,
            },
            byzantine::Action::Train { samples } => {
                let trainable = self.trainable(samples.len());
                match TrainData::new(&self.learners.shape, &samples) {
                    Ok(data) if trainable => {
                        jobs.push(self.train_job(robot, w.phase, &chain.weights, data));
                        Plan::TrainForged {
                            job: jobs.len() - 1,
                            base_round,
                        }
                    }
                    _ => Plan::Skip {
                        reason: SkipReason::NotEnoughData,
                        base_round,
                    },
                }
            }
        })
    }

    /// The submission of `weights` claiming `samples` by `robot` and its identity in the
    /// learning report: a transaction signed by its own node, or a baseline's write or upload.
    fn submission(&self, robot: RobotId, weights: Vec<i64>, samples: u64) -> (Digest, Submission) {
        let weights: Arc<[i64]> = Arc::from(weights);
        if self.config.learn.aggregation == Aggregation::Chain {
            let call = Call::SubmitModel { weights, samples };
            let tx = self
                .state
                .ledger
                .make_tx(robot, self.learners.stake_units, call);
            return (tx.hash_and_size().0, Submission::Tx(tx));
        }
        let a = &self.state.aggregation;
        (
            a.next_hash(robot, samples, weights.clone()),
            Submission::Baseline(a.submission(robot, samples, weights)),
        )
    }

    /// The report and submission of a forged model claiming `claimed` samples (a model that
    /// does not convert to fixed point is skipped, as an honest one is).
    fn forged(
        &self,
        robot: RobotId,
        weights: &[f32],
        claimed: u32,
    ) -> (LearnAction, Option<Submission>) {
        match learn::to_fixed(weights, self.config.contract.weight_scale) {
            Ok(fixed) => {
                let (tx, submission) = self.submission(robot, fixed, u64::from(claimed));
                let action = LearnAction::Forged {
                    tx,
                    claimed_samples: claimed,
                };
                (action, Some(submission))
            }
            Err(_) => (
                LearnAction::Skipped {
                    reason: SkipReason::NonFiniteModel,
                },
                None,
            ),
        }
    }

    /// The report and submission of an honest training.
    fn trained(&self, robot: RobotId, outcome: &TrainOutcome) -> (LearnAction, Option<Submission>) {
        match learn::to_fixed(&outcome.weights, self.config.contract.weight_scale) {
            Ok(fixed) => {
                let (tx, submission) =
                    self.submission(robot, fixed, u64::from(outcome.train_samples));
                let action = LearnAction::Trained {
                    tx,
                    train_samples: outcome.train_samples,
                    val_samples: outcome.val_samples,
                    val_loss: outcome.val_loss,
                    final_train_loss: outcome.final_train_loss,
                };
                (action, Some(submission))
            }
            Err(_) => (
                LearnAction::Skipped {
                    reason: SkipReason::NonFiniteModel,
                },
                None,
            ),
        }
    }

    /// Starts on the pool the trainings of the honest phases due within the look-ahead window
    /// that are not yet speculated from their robot's current model (a speculation from an
    /// older model is replaced, and cancelled if it has not started).
    fn speculate(&mut self, now: SimTime) {
        let horizon = now.0 + self.ahead.window_ticks * self.tick_ms;
        let mut started = Vec::new();
        for (&(due_ms, r), (phase, samples)) in
            self.ahead.upcoming.range(..=(horizon, RobotId::MAX))
        {
            debug_assert!(due_ms > now.0, "due phases were taken out");
            let view = self.preview(r);
            let unchanged = self
                .ahead
                .speculated
                .get(&(r, *phase))
                .is_some_and(|(digest, _)| *digest == view.digest);
            if unchanged || !self.trainable(samples.len()) || self.submitted(r) {
                continue;
            }
            let Ok(data) = TrainData::new(&self.learners.shape, samples) else {
                continue;
            };
            let job = self.train_job(r, *phase, &view.weights, data);
            started.push(((r, *phase), (view.digest, Spawned::start(job))));
        }
        self.ahead.speculated.extend(started);
    }

    /// Emits the reports and submissions whose training has finished by `now`, in time then
    /// robot order.
    fn release_submissions(&mut self, now: SimTime) {
        while let Some(entry) = self.learners.pending.first_entry() {
            let (at, _, _) = *entry.key();
            if at > now.0 {
                break;
            }
            let Pending { report, submission } = entry.remove();
            // A training finished between ticks is submitted at the tick that follows.
            self.emit(now, Event::Learn(report));
            match submission {
                Some(Submission::Tx(tx)) => {
                    self.emit(now, Event::Ledger(LedgerEvent::Submit { tx }));
                }
                Some(Submission::Baseline(event)) => self.emit(now, Event::Aggregation(event)),
                None => {}
            }
        }
    }
}

impl Iterator for Sim {
    type Item = Record;

    fn next(&mut self) -> Option<Record> {
        while self.queue.is_empty() && !self.finished {
            self.advance();
        }
        self.queue.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Preset;
    use crate::event::Checkpoint;

    fn short_config() -> Config {
        let mut c = Preset::Smoke.config();
        c.run.duration_s = 30.0;
        c
    }

    #[test]
    fn a_run_is_a_pure_function_of_seed_and_config() {
        let a: Vec<Record> = Sim::new(short_config(), 3).unwrap().collect();
        let b: Vec<Record> = Sim::new(short_config(), 3).unwrap().collect();
        let c: Vec<Record> = Sim::new(short_config(), 4).unwrap().collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_eq!(a.iter().filter(|r| r.kind() == "tick").count(), 300);
        assert!(matches!(
            a.last(),
            Some(Record::Checkpoint(Checkpoint {
                cause: CheckpointCause::End,
                ..
            }))
        ));
    }

    #[test]
    fn the_speculation_window_does_not_change_a_single_record() {
        let mut config = short_config();
        config.run.duration_s = 250.0;
        let plain: Vec<Record> = Sim::with_lookahead(config.clone(), 5, 0).unwrap().collect();
        let wide: Vec<Record> = Sim::with_lookahead(config.clone(), 5, 60_000)
            .unwrap()
            .collect();
        let default: Vec<Record> = Sim::new(config, 5).unwrap().collect();
        assert!(plain.iter().any(|r| r.kind() == "learn"), "the run trains");
        assert_eq!(plain, wide);
        assert_eq!(plain, default);
    }

    #[test]
    fn background_trainings_give_the_same_records_on_one_pool_thread_or_four() {
        // On one pool thread the driver must take queued trainings itself (a driver that
        // only waited would deadlock a pool whose one thread runs it); on four, the
        // speculated trainings finish in any order.
        let mut config = short_config();
        config.run.duration_s = 250.0;
        let on = |threads: usize| -> Vec<Record> {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            let config = config.clone();
            pool.install(move || Sim::with_lookahead(config, 5, 20_000).unwrap().collect())
        };
        let one = on(1);
        assert!(one.iter().any(|r| r.kind() == "learn"), "the run trains");
        assert_eq!(one, on(4));
        assert_eq!(
            one,
            Sim::with_lookahead(config, 5, 0)
                .unwrap()
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn folding_the_events_rebuilds_every_checkpoint() {
        let config = short_config();
        let mut state = State::genesis(&config, 9).unwrap();
        let mut checked = 0;
        for record in Sim::new(config, 9).unwrap() {
            match record {
                Record::Event { time, event } => state.apply(time, &event).unwrap(),
                Record::Checkpoint(c) => {
                    assert_eq!(state.checkpoint(c.time, c.cause), c);
                    checked += 1;
                }
            }
        }
        assert!(
            checked >= 3,
            "blocks are sealed every 10 s: {checked} checkpoints"
        );
    }
}

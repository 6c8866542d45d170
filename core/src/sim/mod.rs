//! The driver: turns a seed and a configuration into the run's records, folding each event into
//! the reduced [`State`] as it goes.
//!
//! Two halves, kept apart on purpose:
//! - [`State`] ([`crate::state`]) is everything the reducers rebuild from events (the world,
//!   every node's ledger with its contract states, the robots' measurements): replaying a log
//!   re-creates it bit-exactly without any of the driver's agents.
//! - [`Sim`] owns the agents that *decide* events from the current state and their own random
//!   streams: the robots' controllers, the aggregation's agents (`protocol.rs`: the ledger's
//!   sealing and gossip scheduler, [`crate::ledger::Network`], or the stigmergy's gossip) and
//!   the learning loop (`learning.rs`: training, Byzantine forging, submitting). A decision
//!   becomes an [`Event`], the event is folded (`recorder.rs`), then recorded.
//!
//! One tick of 0.1 s: the controllers' wheel commands (a `Tick` event) move the world to the
//! tick's end; the ledger events due until then follow (a checkpoint after every sealed block);
//! then every robot whose learning phase is due reads the shared model from its own chain,
//! trains on its current data set (or forges a model), and submits (a `Learn` report and a
//! `Submit` event). Trainings due in the same tick run in parallel and are combined in robot
//! order.

mod gas_estimate;
mod learning;
mod protocol;
mod recorder;
mod speculation;
pub mod timing;

use std::collections::{BTreeMap, VecDeque};

use crate::byzantine::{self, plugin::Plugins};
use crate::config::{Config, GasLimitRule};
use crate::data::Sample;
use crate::event::{CheckpointCause, Event, Reconfiguration, Record};
use crate::faults::FaultSchedule;
use crate::learn::{self, Spawned, TrainData, TrainJob, TrainOutcome};
use crate::ledger::LedgerEvent;
use crate::metrics::{LearnAction, LearnReport, SkipReason};
use crate::rng::{self, Purpose};
use crate::state::{SimError, State};
use crate::types::{Digest, RobotId, SimTime};
use crate::world::heterogeneity::PositionHeterogeneity;
use crate::world::{Controllers, TickEvent, World};

use learning::{Decided, Learners, Pending, Plan, Waiting};
use protocol::{Protocol, RadioTick, Submission};
use recorder::Recorder;
pub use recorder::{Part, Profiler};
use speculation::Horizon;

/// How far (simulated ms) the look-ahead world runs before the reduced state by default: the
/// window in which honest trainings are speculated in parallel. A performance knob only: the
/// records do not depend on it (a test runs with 0, with this and with a wider window).
/// 10 s: wider windows gained almost nothing, narrower ones cost wall time, and 10 s wastes the
/// fewest speculated trainings, which matters when two runs share the cores (`sweep --jobs 2`);
/// see docs/PERFORMANCE.md, "The paper run".
pub const DEFAULT_LOOKAHEAD_MS: u64 = 10_000;

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
    /// How far ahead, within the window, trainings are speculated now (`speculation.rs`).
    horizon: Horizon,
}

/// The driver of one run: an iterator over its records.
pub struct Sim {
    config: Config,
    seed: u64,
    /// The reduced state and the records decided but not yet handed out.
    rec: Recorder,
    /// The aggregation's agents: what the radio carries, how models are shared.
    protocol: Protocol,
    ahead: LookAhead,
    learners: Learners,
    tick_ms: u64,
    total_ticks: u64,
    next_tick: u64,
    genesis_checked: bool,
    finished: bool,
    /// Reconfigurations still to come, in time order, with their parsed configurations.
    reconfigurations: VecDeque<(Reconfiguration, Config)>,
    /// The faults of the run (driver side).
    faults: FaultSchedule,
}

impl Sim {
    /// A run of `config` seeded with `seed`, at time 0.
    pub fn new(config: Config, seed: u64) -> Result<Sim, SimError> {
        Sim::with_lookahead(config, seed, DEFAULT_LOOKAHEAD_MS)
    }

    /// A run whose speculative training window is `lookahead_ms` (0: each robot trains when
    /// due, alone). The records are the same for every window.
    pub fn with_lookahead(config: Config, seed: u64, lookahead_ms: u64) -> Result<Sim, SimError> {
        Sim::with_plugins(config, seed, lookahead_ms, &Plugins::none())
    }

    /// A run offered `plugins` (`byzantine.kind = "plugin"` takes its agent from them; an
    /// error names a plug-in the configuration names and `plugins` lacks).
    pub fn with_plugins(
        config: Config,
        seed: u64,
        lookahead_ms: u64,
        plugins: &Plugins,
    ) -> Result<Sim, SimError> {
        let state = State::genesis(&config, seed)?;
        let tick_ms = (config.run.tick_s * 1000.0).round() as u64;
        assert!(tick_ms > 0, "validated config has tick_s >= 1 ms");
        let learners = Learners::new(&config, seed, plugins)?;
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
            horizon: Horizon::new(lookahead_ms.div_ceil(tick_ms)),
        };
        Ok(Sim {
            total_ticks: config.ticks(),
            protocol: Protocol::new(&config, seed),
            faults: FaultSchedule::new(&config.faults, config.world.robots),
            ahead,
            learners,
            config,
            seed,
            rec: Recorder::new(state),
            tick_ms,
            next_tick: 0,
            genesis_checked: false,
            finished: false,
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
        Sim::forked_with(config, seed, reconfigurations, &Plugins::none())
    }

    /// [`Sim::forked`] offered `plugins` (every configuration, the root's and each
    /// reconfiguration's, may name one of them).
    pub fn forked_with(
        config: Config,
        seed: u64,
        reconfigurations: &[Reconfiguration],
        plugins: &Plugins,
    ) -> Result<Sim, SimError> {
        let mut sim = Sim::with_plugins(config, seed, DEFAULT_LOOKAHEAD_MS, plugins)?;
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
            let next = crate::config::parse_config(&change.config_toml, "the reconfiguration")
                .map_err(|e| fail(e.to_string()))?;
            current
                .check_reconfiguration(&next)
                .map_err(|e| fail(e.to_string()))?;
            byzantine::agent(&next.byzantine, plugins).map_err(fail)?;
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
        self.rec.profiler = Some(profiler);
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
        &self.rec.state
    }

    /// How the robots' training data differ in position over the learning phases so far
    /// (`world/heterogeneity.rs`): every robot's phase counts, trained, skipped or Byzantine,
    /// so a run without training measures the data it would have trained on.
    pub fn position_heterogeneity(&self) -> PositionHeterogeneity {
        self.learners.positions.measure()
    }

    /// Simulated time reached and total, in milliseconds.
    pub fn progress(&self) -> (u64, u64) {
        (
            self.next_tick * self.tick_ms,
            self.total_ticks * self.tick_ms,
        )
    }

    /// Decides, folds and queues the records of the next tick.
    fn advance(&mut self) {
        if !self.genesis_checked {
            self.genesis_checked = true;
            self.rec.checkpoint(SimTime(0), CheckpointCause::Genesis);
            return;
        }
        if self.next_tick == self.total_ticks {
            let end = self.rec.state.world.time();
            self.rec.checkpoint(end, CheckpointCause::End);
            self.finished = true;
            return;
        }
        let time = SimTime(self.next_tick * self.tick_ms);
        self.rec.switch(Part::World);
        self.run_ahead();
        let tick = self
            .ahead
            .ticks
            .pop_front()
            .expect("the look-ahead world is ahead");
        self.rec.emit(time, Event::Tick(tick));
        self.next_tick += 1;
        let now = SimTime(self.next_tick * self.tick_ms);
        debug_assert_eq!(now, self.rec.state.world.time());

        self.rec.switch(Part::Ledger);
        let peers = self.peers(now);
        let radio = RadioTick {
            time,
            now,
            peers: &peers,
            checkpoint_period_ms: self.period_checkpoint_ms(),
        };
        self.protocol.tick(&mut self.rec, &self.faults, &radio);

        self.rec.switch(Part::Learning);
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

    /// The checkpoint period of a run without blocks: the block period, in ms.
    fn period_checkpoint_ms(&self) -> u64 {
        ((self.config.ledger.block_period_s * 1000.0).round() as u64).max(1)
    }

    /// The radio's peer sets at `now` with the links the faults cut removed.
    fn peers(&self, now: SimTime) -> Vec<Vec<RobotId>> {
        let robots = self.config.world.robots;
        let mut peers: Vec<Vec<RobotId>> = (0..robots)
            .map(|r| self.rec.state.world.peers(r).to_vec())
            .collect();
        if self.faults.cuts_links() {
            let x: Vec<f64> = self.rec.state.world.poses().iter().map(|p| p.x).collect();
            let top = (0..robots)
                .map(|r| self.rec.state.ledger.head(r).1)
                .max()
                .unwrap_or(0);
            let in_turn = ((top + 1) % u64::from(robots)) as RobotId;
            self.faults.filter_peers(&mut peers, now.0, &x, in_turn);
        }
        peers
    }

    /// Takes over `config` at the end of the tick ending at `now`: the event (the contract's
    /// rules for later blocks), the agents' new settings, a fresh speculation window (the
    /// trainings speculated under the old settings are dropped) and a checkpoint.
    fn reconfigure(&mut self, now: SimTime, change: Reconfiguration, config: Config) {
        self.rec.emit(now, Event::Reconfigure(change));
        self.learners.reconfigure(&config, self.seed);
        let a = &mut self.ahead;
        a.speculated.clear();
        a.upcoming.clear();
        a.next_due_ms.clone_from(&self.learners.next_due_ms);
        a.phases.clone_from(&self.learners.phases);
        // Phases the look-ahead world has already passed are not captured: they read the
        // reduced world's data set when due.
        let ahead_ms = a.next_tick * self.tick_ms;
        for (r, (due, phase)) in a
            .next_due_ms
            .iter_mut()
            .zip(a.phases.iter_mut())
            .enumerate()
        {
            while *due <= ahead_ms {
                *phase += 1;
                *due = self.learners.slot(r as RobotId, *phase).begin_ms;
            }
        }
        self.total_ticks = config.ticks();
        self.config = config;
        self.rec.checkpoint(now, CheckpointCause::Reconfigure);
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
                    if !self.learners.byzantine[i] && !self.learners.withheld[i] {
                        a.upcoming
                            .insert((a.next_due_ms[i], r), (a.phases[i], a.world.dataset(r)));
                    }
                    a.phases[i] += 1;
                    a.next_due_ms[i] = self.learners.slot(r, a.phases[i]).begin_ms;
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
        let mut decided = Vec::with_capacity(due.len() + waiting.len());
        self.ask_waiting_again(waiting, now, &mut jobs, &mut decided);
        for &r in &due {
            decided.extend(self.begin_phase(r, now, &mut jobs));
        }
        let outcomes = self.train(now, jobs);
        for d in decided {
            self.queue_submission(now, d, &outcomes);
        }
    }

    /// Asks the attacks that waited in an earlier phase again: a decision joins `decided`; an
    /// attack that still waits when its robot's next phase is due gives that phase up (a
    /// `Waited` report).
    fn ask_waiting_again(
        &mut self,
        waiting: Vec<(RobotId, Waiting)>,
        now: SimTime,
        jobs: &mut Vec<TrainJob>,
        decided: &mut Vec<Decided>,
    ) {
        for (r, w) in waiting {
            self.learners.waiting.remove(&r);
            let last_chance = self.learners.next_due_ms[r as usize] <= now.0;
            match self.byzantine_plan(r, w, now, last_chance, jobs) {
                Some(plan) => decided.push(Decided {
                    robot: r,
                    phase: w.phase,
                    ready_ms: w.ready_ms,
                    plan,
                }),
                None if last_chance => {
                    let base_round = self.protocol.current(&self.rec.state, r).round;
                    let report = LearnReport {
                        robot: r,
                        base_round,
                        action: LearnAction::Skipped {
                            reason: SkipReason::Waited,
                        },
                    };
                    self.rec.emit(now, Event::Learn(report));
                }
                None => {
                    self.learners.waiting.insert(r, w);
                }
            }
        }
    }

    /// Starts `robot`'s phase due by `now`: advances its schedule, lets the aggregation know,
    /// and decides (`None`: its attack waits).
    fn begin_phase(
        &mut self,
        robot: RobotId,
        now: SimTime,
        jobs: &mut Vec<TrainJob>,
    ) -> Option<Decided> {
        let i = robot as usize;
        let phase = self.learners.phases[i];
        let due_ms = self.learners.next_due_ms[i];
        let slot = self.learners.slot(robot, phase);
        // The training takes its time on the schedule from the tick the phase begins in.
        let ready_ms = now.0 + (slot.ready_ms - slot.begin_ms);
        self.learners.phases[i] += 1;
        self.learners.next_due_ms[i] = self.learners.slot(robot, phase + 1).begin_ms;
        self.learners.timing.forget(robot, phase + 1);
        let data = self.rec.state.world.samples(robot);
        let train = learn::split_point(data.len(), self.config.learn.train_fraction);
        self.learners.positions.count(i, phase, data, train);
        let captured = self.ahead.upcoming.remove(&(due_ms, robot));
        let speculated = self.ahead.speculated.remove(&(robot, phase));
        if self.learners.withheld[i] {
            // `learn.withheld`: the phase passes without training, report or submission.
            return None;
        }
        let had_speculation = speculated.is_some();
        self.protocol.phase_begins(&mut self.rec, now, robot);
        let plan = if self.learners.byzantine[i] {
            let w = Waiting { phase, ready_ms };
            let plan = self.byzantine_plan(robot, w, now, false, jobs);
            if plan.is_none() {
                self.learners.waiting.insert(robot, w);
            }
            plan?
        } else {
            let plan = self.honest_plan(robot, phase, now, captured, speculated, jobs);
            if had_speculation {
                self.ahead.horizon.judge(matches!(plan, Plan::Ready { .. }));
            }
            plan
        };
        Some(Decided {
            robot,
            phase,
            ready_ms,
            plan,
        })
    }

    /// An honest robot's plan for `phase`: skip, use the training speculated from the model
    /// it starts from, or train now (added to `jobs`) on the data set the look-ahead world
    /// `captured` (the reduced world's, if it was not captured).
    fn honest_plan(
        &self,
        robot: RobotId,
        phase: u64,
        now: SimTime,
        captured: Option<(u64, Vec<Sample>)>,
        speculated: Option<(Digest, Spawned)>,
        jobs: &mut Vec<TrainJob>,
    ) -> Plan {
        let view = self.protocol.current(&self.rec.state, robot);
        let base_round = view.round;
        if let Some(reason) = self.cannot_submit(robot, now) {
            return Plan::Skip { reason, base_round };
        }
        let samples = match captured {
            Some((captured_phase, samples)) => {
                debug_assert_eq!(captured_phase, phase);
                debug_assert!(
                    samples == self.rec.state.world.dataset(robot),
                    "the look-ahead world diverged"
                );
                samples
            }
            None => self.rec.state.world.dataset(robot),
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
                jobs.push(self.train_job(robot, phase, &view.weights, data));
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
    }

    /// Runs the trainings due now and returns their outcomes in `jobs` order. The due
    /// trainings go to the pool first, then the window's speculated ones; this thread takes
    /// any due one no pool thread has started, and waits for the others.
    fn train(&mut self, now: SimTime, jobs: Vec<TrainJob>) -> Vec<TrainOutcome> {
        let due_jobs: Vec<Spawned> = jobs.into_iter().map(Spawned::start).collect();
        if !due_jobs.is_empty() {
            self.speculate(now);
        }
        due_jobs.into_iter().map(Spawned::wait).collect()
    }

    /// Carries out a decided phase: its report and submission wait for the training's
    /// duration (`outcomes`: the trainings of the plans that trained now).
    fn queue_submission(&mut self, now: SimTime, decided: Decided, outcomes: &[TrainOutcome]) {
        let Decided {
            robot: r,
            phase,
            ready_ms,
            plan,
        } = decided;
        // A phase's submission leaves a training duration after the phase began, or now if a
        // waiting attack decided later than that.
        let submit_at = ready_ms.max(now.0);
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

    /// Why `robot` cannot submit now, in its own node's view: it is down, its balance is below
    /// the stake (when the rule stakes), or it already submitted in the current round.
    fn cannot_submit(&self, robot: RobotId, now: SimTime) -> Option<SkipReason> {
        if self.faults.is_down(robot, now.0) {
            Some(SkipReason::Crashed)
        } else if self
            .protocol
            .lacks_stake(&self.rec.state, robot, self.learners.stake_units)
        {
            Some(SkipReason::InsufficientStake)
        } else if !self.learners.timing.submits_blind()
            && self.protocol.submitted(&self.rec.state, robot)
        {
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
        let chain = self.protocol.chain_view(&self.rec.state, robot);
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
            chain: &chain,
            params: self.rec.state.ledger.current_params(),
            weight_scale: self.config.contract.weight_scale,
            coalition: &self.learners.byzantine,
            world: &self.rec.state.world,
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
    /// learning report.
    fn submission(&self, robot: RobotId, weights: Vec<i64>, samples: u64) -> (Digest, Submission) {
        let stake_units = self.learners.stake_units;
        self.protocol
            .submission(&self.rec.state, robot, stake_units, weights, samples)
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

    /// Starts on the pool the trainings of the honest phases due within the speculation horizon
    /// (`speculation.rs`; at most the look-ahead window)
    /// that are not yet speculated from their robot's current model (a speculation from an
    /// older model is replaced, and cancelled if it has not started).
    fn speculate(&mut self, now: SimTime) {
        let horizon = now.0 + self.ahead.horizon.ticks() * self.tick_ms;
        let mut started = Vec::new();
        let mut replaced = 0;
        for (&(due_ms, r), (phase, samples)) in
            self.ahead.upcoming.range(..=(horizon, RobotId::MAX))
        {
            debug_assert!(due_ms > now.0, "due phases were taken out");
            let view = self.protocol.preview(&self.rec.state, r);
            let before = self.ahead.speculated.get(&(r, *phase));
            let unchanged = before.is_some_and(|(digest, _)| *digest == view.digest);
            let stale = before.is_some() && !unchanged;
            if unchanged
                || !self.trainable(samples.len())
                || self.protocol.submitted(&self.rec.state, r)
            {
                continue;
            }
            let Ok(data) = TrainData::new(&self.learners.shape, samples) else {
                continue;
            };
            let job = self.train_job(r, *phase, &view.weights, data);
            replaced += usize::from(stale);
            started.push(((r, *phase), (view.digest, Spawned::start(job))));
        }
        self.ahead.speculated.extend(started);
        for _ in 0..replaced {
            self.ahead.horizon.judge(false);
        }
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
            if self.learners.withheld[report.robot as usize] {
                // Queued before a fork withheld the robot: it never leaves.
                continue;
            }
            let (report, submission) = self.estimated(report, submission, now);
            // A training finished between ticks is submitted at the tick that follows.
            self.rec.emit(now, Event::Learn(report));
            match submission {
                Some(Submission::Tx(tx)) => {
                    self.rec
                        .emit(now, Event::Ledger(LedgerEvent::Submit { tx }));
                }
                Some(Submission::Baseline(event)) => self.rec.emit(now, Event::Aggregation(event)),
                None => {}
            }
        }
    }
}

impl Sim {
    /// Under `contract.gas_limit = "estimate"`, a transaction as its robot sends it now: with
    /// its node's gas estimate, or not at all when the estimate fails (`gas_estimate.rs`).
    fn estimated(
        &self,
        report: LearnReport,
        submission: Option<Submission>,
        now: SimTime,
    ) -> (LearnReport, Option<Submission>) {
        let contract = &self.config.contract;
        match submission {
            Some(Submission::Tx(draft)) if contract.gas_limit == GasLimitRule::Estimate => {
                match gas_estimate::sent(&self.rec.state, contract, &draft, now) {
                    Ok(tx) => (
                        gas_estimate::reported(report, Ok(&tx)),
                        Some(Submission::Tx(tx)),
                    ),
                    Err(failed) => (gas_estimate::reported(report, Err(failed)), None),
                }
            }
            other => (report, other),
        }
    }
}

impl Iterator for Sim {
    type Item = Record;

    fn next(&mut self) -> Option<Record> {
        while self.rec.queue.is_empty() && !self.finished {
            self.advance();
        }
        self.rec.queue.pop_front()
    }
}

#[cfg(test)]
mod tests;

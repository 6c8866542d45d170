//! The world: arena, robots, physics, sensing and trajectory data (docs/SPEC.md section 1).
//!
//! [`World`] is the reduced state, folded tick by tick by [`World::apply`] from [`TickEvent`]s
//! (every robot's wheel command); [`Controllers`] is the driver-side decision maker whose
//! choices become those events. One tick of `apply`, in order:
//! 1. physics ([`physics`]): robots move in robot order; a move that would overlap a wall, an
//!    obstacle or a robot is not taken (the robot turns but stays);
//! 2. overlap check (counted in `collisions`, must stay 0);
//! 3. range-and-bearing contacts ([`sensors`]), packet drop and noise drawn from each
//!    receiver's `Purpose::RangeAndBearing` stream (kept in the state), trajectory recording
//!    and expiry ([`crate::data`]);
//! 4. every `peer_refresh_s`, the peer sets become the current contacts.
//!
//! Submodules: [`arena`] (walls, obstacles, grid), [`physics`], [`sensors`], [`controller`].

pub mod arena;
pub mod behaviour;
pub mod controller;
mod epuck;
pub mod flocking;
pub mod foraging;
pub mod foraging_flowfl;
pub mod heterogeneity;
mod home_range;
mod khepera;
pub mod par;
pub mod physics;
pub mod place;
mod sense;
pub mod sensors;
pub mod steering;

use std::collections::VecDeque;

use rayon::ThreadPool;
use serde::{Deserialize, Serialize};

use crate::config::{
    Avoidance, Behaviour, Config, ConfigError, ForagingRule, MixedAssign, WindowRule,
};
use crate::data::{HeldoutObserver, Recorder, Recording, Sample};
use crate::rng::{self, Purpose, Rng};
use crate::types::{Digest, RobotId, SimTime};

pub use arena::{Arena, Obstacle};
pub use behaviour::{Behaviours, Food, Forager, Nest};
pub use controller::{Controllers, TickEvent};
pub use par::Workers;
use physics::{Body, RobotGrid};
pub use steering::WheelCommand;

/// What can go wrong building a world or folding an event into it.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    /// The obstacles or robots do not fit.
    #[error("cannot place {what}: {why}")]
    Placement {
        /// What could not be placed.
        what: String,
        /// Why, naming the parameters.
        why: String,
    },
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A tick event that does not fit this world.
    #[error("tick event at {time}: {why}")]
    Event {
        /// The world's time when the event came.
        time: SimTime,
        /// What is wrong.
        why: String,
    },
}

/// A robot's pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// x in metres.
    pub x: f64,
    /// y in metres.
    pub y: f64,
    /// Heading in radians, in [-pi, pi].
    pub theta: f64,
}

/// Summary figures of the world, for `summary.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorldStats {
    /// Overlaps detected after a step (must be 0).
    pub collisions: u64,
    /// Mean number of robots in range-and-bearing contact per robot and tick.
    pub mean_neighbours: f64,
    /// Samples collected per robot per 600 s: mean over robots.
    pub samples_per_robot_per_600s: f64,
    /// Standard deviation over robots of the above (n - 1 denominator).
    pub samples_per_robot_per_600s_std: f64,
    /// Partial trajectories discarded because a tick was missed.
    pub trajectories_discarded: u64,
    /// Samples ever completed, all robots.
    pub samples_collected: u64,
    /// Moves refused because they would have overlapped something.
    pub blocked_moves: u64,
    /// Range-and-bearing messages lost to packet drop.
    pub messages_dropped: u64,
    /// Samples in the held-out set.
    pub heldout_samples: u64,
    /// Motion heterogeneity between robots' current data sets, at the end of the run
    /// (`data::heterogeneity`: the bias-corrected Cramer's V of the robots x (speed x turn
    /// cell) table). The key keeps its first name, `data_heterogeneity`, so committed
    /// summaries still read; it measures motion, not position (see `position_heterogeneity`).
    #[serde(default)]
    pub data_heterogeneity: f64,
    /// Position heterogeneity of the data the robots trained on (or would have), over every
    /// learning phase of the run (`world/heterogeneity.rs`). Set by the driver's caller from
    /// `Sim::position_heterogeneity`; absent in summaries written before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_heterogeneity: Option<heterogeneity::PositionHeterogeneity>,
    /// Items delivered to the nest by foragers (0 without foraging).
    #[serde(default)]
    pub foraging_deliveries: u64,
}

/// Parameters derived from the configuration, in the units the reducer uses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Params {
    tick_ms: u64,
    body: Body,
    proximity_range_m: f64,
    /// Unit direction of each proximity sensor relative to the heading.
    sensor_dirs: Vec<(f64, f64)>,
    rab_range_m: f64,
    rab_noise_std_m: f64,
    rab_occlusion: bool,
    rab_packet_drop: f64,
    peer_refresh_ticks: u64,
    recording: Recording,
    /// False for the held-out observer's copy: physics only.
    sensing: bool,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
struct Counters {
    collisions: u64,
    blocked_moves: u64,
    contact_ticks: u64,
    messages_dropped: u64,
}

/// Buffers rebuilt from the state; not part of it (skipped by serde, ignored by `==`).
#[derive(Clone, Debug, Default)]
struct Scratch {
    grid: RobotGrid,
    /// The tick the grid indexes, if any.
    grid_tick: Option<u64>,
    contacts: Vec<Vec<RobotId>>,
    heard: Vec<RobotId>,
    /// Each robot's reading words of the tick, when sensed in parallel (`sense.rs`).
    words: Vec<Vec<u64>>,
    /// Each robot's contacts after it (`World::contacts_par`).
    later: Vec<Vec<RobotId>>,
    /// Each robot's squared distance to the nearest other robot within `rab_range_m`, found by
    /// the parallel contacts' search (`World::contacts_par`) at tick `nearest_tick`: the next
    /// step's test of which robots move alone (`physics::step_parallel`).
    nearest: Vec<f64>,
    /// The tick `nearest` describes, if any.
    nearest_tick: Option<u64>,
}

impl PartialEq for Scratch {
    fn eq(&self, _: &Scratch) -> bool {
        true
    }
}

/// The reduced state of the world.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct World {
    params: Params,
    arena: Arena,
    tick: u64,
    poses: Vec<Pose>,
    peers: Vec<Vec<RobotId>>,
    /// Range-and-bearing noise and drop, per receiving robot.
    rab_rngs: Vec<Rng>,
    recorders: Vec<Recorder>,
    heldout: Vec<Sample>,
    counters: Counters,
    /// blake3 chain over every completed sample (robot, time, points).
    sample_chain: Digest,
    /// A cheap running mix of every recorded reading (covers trajectories in progress).
    reading_mix: u64,
    /// Digest of the parts fixed at construction (parameters, arena, held-out set).
    fixed_digest: Digest,
    /// What later issues added (behaviours, robot occlusion, window rule); left out of the
    /// serialized state and of the digests while at its default, so that worlds which do not
    /// use it keep their records.
    #[serde(default, skip_serializing_if = "Extra::is_default")]
    extra: Extra,
    #[serde(skip)]
    scratch: Scratch,
}

/// The world's parameters and state beyond the original ones (see `World::extra`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
struct Extra {
    /// Robots block range-and-bearing line of sight (`world.rab_robot_occlusion`).
    rab_robot_occlusion: bool,
    /// When a window becomes a sample (`data.window_rule`).
    window_rule: WindowRule,
    /// The behaviours, unless every robot runs the default avoidance walk.
    behaviours: Option<Behaviours>,
    /// The proximity sensors' model (`world.avoidance`; `epuck.rs`).
    #[serde(default, skip_serializing_if = "is_turn")]
    avoidance: Avoidance,
    /// Refused translations slide along the contact (`world.slide_on_contact`).
    #[serde(default, skip_serializing_if = "is_false")]
    slide_on_contact: bool,
}

fn is_turn(a: &Avoidance) -> bool {
    *a == Avoidance::Turn
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// Angle of proximity sensor `k` from the heading, counter-clockwise: evenly spaced from the
/// heading (also the Khepera IV's ring, `"khepera"`), or the e-puck's ring from 11.25 degrees
/// (`world.avoidance = "epuck"`).
/// `n` is the number of sensors.
pub(crate) fn sensor_angle(avoidance: Avoidance, k: u32, n: u32) -> f64 {
    let start = match avoidance {
        Avoidance::Turn | Avoidance::Khepera => 0.0,
        Avoidance::Epuck => epuck::START_ANGLE,
    };
    start + 2.0 * std::f64::consts::PI * f64::from(k) / f64::from(n)
}

impl Extra {
    fn new(config: &Config, seed: u64, arena: &Arena, poses: &[Pose]) -> Result<Extra, WorldError> {
        Ok(Extra {
            rab_robot_occlusion: config.world.rab_robot_occlusion,
            window_rule: config.data.window_rule,
            behaviours: Behaviours::new(config, seed, arena, poses)?,
            avoidance: config.world.avoidance,
            slide_on_contact: config.world.slide_on_contact,
        })
    }

    fn is_default(&self) -> bool {
        *self == Extra::default()
    }
}

impl World {
    /// The world at time 0 of the run seeded with `seed`: obstacles from `Purpose::Obstacles`,
    /// robots from `Purpose::Placement`, and the held-out set (see [`World::heldout`]).
    pub fn new(config: &Config, seed: u64) -> Result<World, WorldError> {
        config.validate()?;
        let mut world = World::build(config, seed, seed, true)?;
        world.heldout = heldout_set(config, seed)?;
        world.fixed_digest = world.compute_fixed_digest();
        Ok(world)
    }

    /// A world with obstacles from `seed` and robots from `placement_seed`, with or without
    /// sensing (the held-out observer's copy has none).
    fn build(
        config: &Config,
        seed: u64,
        placement_seed: u64,
        sensing: bool,
    ) -> Result<World, WorldError> {
        let w = &config.world;
        let tick_ms = SimTime::from_secs(config.run.tick_s).0;
        let body = Body {
            radius_m: w.robot_radius_m,
            wheel_base_m: w.wheel_base_m,
            dt_s: tick_ms as f64 / 1000.0,
        };
        let sensor_dirs = (0..w.proximity_sensors)
            .map(|k| {
                let a = sensor_angle(w.avoidance, k, w.proximity_sensors);
                (libm::cos(a), libm::sin(a))
            })
            .collect();
        let params = Params {
            tick_ms,
            body,
            proximity_range_m: w.proximity_range_m,
            sensor_dirs,
            rab_range_m: w.rab_range_m,
            rab_noise_std_m: w.rab_noise_std_m,
            rab_occlusion: w.rab_occlusion,
            rab_packet_drop: w.rab_packet_drop,
            peer_refresh_ticks: ((w.peer_refresh_s / config.run.tick_s).round() as u64).max(1),
            recording: Recording::new(&config.data),
            sensing,
        };
        // The grid cell covers the longest query: RAB range, or proximity reach plus a robot.
        let min_cell = w
            .rab_range_m
            .max(2.0 * w.robot_radius_m + w.proximity_range_m)
            .max(1e-3);
        let arena = Arena::new(w, &mut rng::stream(seed, Purpose::Obstacles, 0), min_cell)?;
        let (poses, grid) = place_robots(
            w,
            &arena,
            &mut rng::stream(placement_seed, Purpose::Placement, 0),
        )?;
        let n = w.robots;
        let extra = Extra::new(config, seed, &arena, &poses)?;
        let mut world = World {
            params,
            arena,
            tick: 0,
            poses,
            peers: vec![Vec::new(); n as usize],
            rab_rngs: (0..n)
                .map(|i| rng::stream(seed, Purpose::RangeAndBearing, i))
                .collect(),
            recorders: vec![Recorder::default(); n as usize],
            heldout: Vec::new(),
            counters: Counters::default(),
            sample_chain: Digest::default(),
            reading_mix: 0,
            fixed_digest: Digest::default(),
            extra,
            scratch: Scratch {
                grid,
                grid_tick: Some(0),
                ..Scratch::default()
            },
        };
        if sensing {
            let mut contacts = std::mem::take(&mut world.scratch.contacts);
            world.contacts(&mut contacts);
            world.peers.clone_from(&contacts);
            world.scratch.contacts = contacts;
        }
        Ok(world)
    }

    /// Checks that `event` fits this world (for events decoded from a file).
    pub fn check(&self, event: &TickEvent) -> Result<(), WorldError> {
        if event.commands.len() != self.poses.len() {
            return Err(WorldError::Event {
                time: self.time(),
                why: format!(
                    "{} wheel commands for {} robots",
                    event.commands.len(),
                    self.poses.len()
                ),
            });
        }
        Ok(())
    }

    /// Folds one tick after [`World::check`]ing the event.
    pub fn try_apply(&mut self, event: &TickEvent) -> Result<(), WorldError> {
        self.check(event)?;
        self.apply(event);
        Ok(())
    }

    /// Folds one tick. The event must hold one command per robot (see [`World::check`]). A
    /// large swarm is stepped on the process's world threads ([`Workers::default_pool`]).
    pub fn apply(&mut self, event: &TickEvent) {
        self.apply_on(event, Workers::default_pool());
    }

    /// [`World::apply`] on `workers` (every choice of threads gives the same bits, `par.rs`).
    pub fn apply_on(&mut self, event: &TickEvent, workers: Workers<'_>) {
        assert_eq!(
            event.commands.len(),
            self.poses.len(),
            "one wheel command per robot"
        );
        match workers.for_robots(self.poses.len()) {
            // The whole tick inside one `install`: the physics' and the sensing's own
            // `install`s then run inline on the pool's thread, and a tick pays one fork from
            // outside the pool instead of two (12-20 us each, docs/PERFORMANCE.md).
            Some(pool) => pool.install(|| self.fold_tick(event, Some(pool))),
            None => self.fold_tick(event, None),
        }
    }

    /// The body of [`World::apply_on`], on `pool`'s threads if given.
    fn fold_tick(&mut self, event: &TickEvent, pool: Option<&ThreadPool>) {
        let mut grid = std::mem::take(&mut self.scratch.grid);
        if self.scratch.grid_tick != Some(self.tick) || grid.robots() != self.poses.len() {
            grid.rebuild(&self.arena.grid, &self.poses);
        }
        let (arena, body, slide) = (&self.arena, &self.params.body, self.extra.slide_on_contact);
        let (poses, commands) = (&mut self.poses, &event.commands);
        self.counters.blocked_moves += match pool {
            Some(pool) => {
                let s = &self.scratch;
                let nearest = (s.nearest_tick == Some(self.tick) && s.nearest.len() == poses.len())
                    .then_some((&s.nearest[..], self.params.rab_range_m));
                physics::step_parallel(
                    pool, arena, &mut grid, poses, body, commands, slide, nearest,
                )
            }
            None => physics::step(arena, &mut grid, poses, body, commands, slide),
        };
        let r = self.params.body.radius_m;
        // Sensing on the threads counts the overlaps in its contacts' search, which sees every
        // overlapping pair when the range-and-bearing range is at least a body's diameter.
        let counted_by_sensing =
            pool.is_some() && self.params.sensing && self.params.rab_range_m >= 2.0 * r;
        let overlaps = match pool {
            _ if counted_by_sensing => None,
            Some(pool) => Some(physics::overlaps_parallel(
                pool,
                &self.arena,
                &grid,
                &self.poses,
                r,
            )),
            None => Some(physics::overlaps(&self.arena, &grid, &self.poses, r)),
        };
        self.tick += 1;
        if let Some(b) = &mut self.extra.behaviours {
            // Under the place rule the behaviours follow the new positions first, so a forager
            // steps only while it stands in the foraging region (`place.rs`).
            b.follow_places(&self.poses);
            foraging::advance(b, &self.poses, self.params.body.radius_m, self.tick);
        }
        self.scratch.grid = grid;
        self.scratch.grid_tick = Some(self.tick);
        self.advance_flowfl_foragers();
        let sensed = if self.params.sensing {
            self.sense(pool)
        } else {
            None
        };
        let overlaps = overlaps
            .or(sensed)
            .expect("the overlaps are counted here or by the sensing");
        debug_assert_eq!(overlaps, 0, "robots overlap after tick {}", self.tick);
        self.counters.collisions += overlaps;
    }

    /// Flow-FL's foragers (`foraging_flowfl.rs`), if any: their step after this tick's physics,
    /// reading the proximity sensors and range-and-bearing contacts of the new positions; the
    /// shared forager states (`Behaviours::foragers`) follow their phases.
    fn advance_flowfl_foragers(&mut self) {
        let Some(mut f) = self.extra.behaviours.as_mut().and_then(|b| b.flowfl.take()) else {
            return;
        };
        let sensors = self.params.sensor_dirs.len();
        f.advance(
            &self.poses,
            |i, out| self.proximity(i as RobotId, out),
            sensors,
            |adj| self.contacts(adj),
        );
        let b = self
            .extra
            .behaviours
            .as_mut()
            .expect("the flowfl state was taken from the behaviours");
        for ((shown, &of), r) in b.foragers.iter_mut().zip(&b.of).zip(&f.robots) {
            if of == Behaviour::Foraging {
                *shown = match r.phase {
                    foraging_flowfl::Phase::Rest => Forager::Rest { until: 0 },
                    foraging_flowfl::Phase::Explore => Forager::Explore,
                    foraging_flowfl::Phase::Return => Forager::Return,
                };
            }
        }
        b.deliveries = f.deliveries;
        b.flowfl = Some(f);
    }

    /// Simulated time of the state.
    pub fn time(&self) -> SimTime {
        SimTime(self.tick * self.params.tick_ms)
    }

    /// Ticks folded so far.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Robot poses, in robot order.
    pub fn poses(&self) -> &[Pose] {
        &self.poses
    }

    /// The arena: walls and obstacles.
    pub fn arena(&self) -> &Arena {
        &self.arena
    }

    /// The behaviours (each robot's, the nest, the food sources, the foragers' states), or
    /// `None` when every robot runs the default avoidance walk.
    pub fn behaviours(&self) -> Option<&Behaviours> {
        self.extra.behaviours.as_ref()
    }

    /// The robots' body radius in metres.
    pub fn robot_radius_m(&self) -> f64 {
        self.params.body.radius_m
    }

    /// The proximity sensors' range in metres.
    pub fn proximity_range_m(&self) -> f64 {
        self.params.proximity_range_m
    }

    /// Number of proximity sensors per robot.
    pub fn proximity_sensors(&self) -> usize {
        self.params.sensor_dirs.len()
    }

    /// The robot's current peer set (robots in range-and-bearing contact at the last refresh,
    /// every `world.peer_refresh_s`), ascending.
    pub fn peers(&self, robot: RobotId) -> &[RobotId] {
        &self.peers[robot as usize]
    }

    /// The robot's current data set (unexpired samples, oldest first).
    pub fn dataset(&self, robot: RobotId) -> Vec<Sample> {
        self.recorders[robot as usize]
            .samples()
            .iter()
            .cloned()
            .collect()
    }

    /// The robot's current data set, borrowed (unexpired samples, oldest first).
    pub fn samples(&self, robot: RobotId) -> &VecDeque<Sample> {
        self.recorders[robot as usize].samples()
    }

    /// Number of samples in the robot's current data set.
    pub fn dataset_len(&self, robot: RobotId) -> usize {
        self.recorders[robot as usize].samples().len()
    }

    /// The fixed held-out set of noise-free samples: `data.heldout_samples` trajectories
    /// recorded by a ground-truth observer in an independent copy of the world (same arena and
    /// obstacles; robots placed and driven by streams derived from `Purpose::Heldout`), which
    /// sees every robot's true position, in windows spread evenly over the whole run. It
    /// depends only on the seed and the configuration and is computed up front, so it is
    /// available from time 0.
    pub fn heldout(&self) -> &[Sample] {
        &self.heldout
    }

    /// Summary figures so far.
    pub fn stats(&self) -> WorldStats {
        let n = self.poses.len() as f64;
        let elapsed_s = self.time().secs();
        let rates: Vec<f64> = self
            .recorders
            .iter()
            .map(|r| {
                if elapsed_s > 0.0 {
                    r.completed() as f64 * 600.0 / elapsed_s
                } else {
                    0.0
                }
            })
            .collect();
        let mean = rates.iter().sum::<f64>() / n;
        let std = if rates.len() > 1 {
            (rates.iter().map(|r| (r - mean) * (r - mean)).sum::<f64>() / (n - 1.0)).sqrt()
        } else {
            0.0
        };
        WorldStats {
            collisions: self.counters.collisions,
            mean_neighbours: if self.tick > 0 {
                self.counters.contact_ticks as f64 / (self.tick as f64 * n)
            } else {
                0.0
            },
            samples_per_robot_per_600s: mean,
            samples_per_robot_per_600s_std: std,
            trajectories_discarded: self.recorders.iter().map(Recorder::discarded).sum(),
            samples_collected: self.recorders.iter().map(Recorder::completed).sum(),
            blocked_moves: self.counters.blocked_moves,
            messages_dropped: self.counters.messages_dropped,
            heldout_samples: self.heldout.len() as u64,
            data_heterogeneity: crate::data::heterogeneity(
                self.recorders.iter().map(Recorder::samples),
                self.params.tick_ms as f64 / 1000.0,
            ),
            foraging_deliveries: self.extra.behaviours.as_ref().map_or(0, |b| b.deliveries),
            position_heterogeneity: None,
        }
    }

    /// A digest of the whole state. Cheap: the data is covered by running digests kept as
    /// samples complete and readings are recorded, so this hashes a few kilobytes.
    pub fn digest(&self) -> Digest {
        let mut h = blake3::Hasher::new();
        h.update(b"swarmfl world v1");
        h.update(&self.fixed_digest.0);
        h.update(&self.tick.to_le_bytes());
        for p in &self.poses {
            for v in [p.x, p.y, p.theta] {
                h.update(&v.to_bits().to_le_bytes());
            }
        }
        for peers in &self.peers {
            h.update(&(peers.len() as u32).to_le_bytes());
            for &j in peers {
                h.update(&j.to_le_bytes());
            }
        }
        for rng in &self.rab_rngs {
            h.update(&rmp_serde::to_vec(rng).expect("rng state serialises"));
        }
        for r in &self.recorders {
            h.update(&r.completed().to_le_bytes());
            h.update(&r.discarded().to_le_bytes());
            h.update(&(r.samples().len() as u64).to_le_bytes());
            for (j, ticks) in r.tracks() {
                h.update(&j.to_le_bytes());
                h.update(&ticks.to_le_bytes());
            }
        }
        let c = &self.counters;
        for v in [
            c.collisions,
            c.blocked_moves,
            c.contact_ticks,
            c.messages_dropped,
            self.reading_mix,
        ] {
            h.update(&v.to_le_bytes());
        }
        h.update(&self.sample_chain.0);
        if let Some(b) = &self.extra.behaviours {
            h.update(&rmp_serde::to_vec(&(&b.foragers, b.deliveries)).expect("states serialise"));
            if b.assign == MixedAssign::Place {
                h.update(&rmp_serde::to_vec(&b.of).expect("behaviours serialise"));
            }
            if let Some(f) = &b.flowfl {
                h.update(&rmp_serde::to_vec(f).expect("flowfl foraging state serialises"));
            }
        }
        h.finalize().into()
    }

    fn compute_fixed_digest(&self) -> Digest {
        let mut bytes =
            rmp_serde::to_vec(&(&self.params, &self.arena)).expect("world parameters serialise");
        if !self.extra.is_default() {
            bytes.extend(rmp_serde::to_vec(&self.extra).expect("world extras serialise"));
        }
        for s in &self.heldout {
            bytes.extend_from_slice(&s.time.0.to_le_bytes());
            for p in &s.points {
                bytes.extend_from_slice(&p[0].to_bits().to_le_bytes());
                bytes.extend_from_slice(&p[1].to_bits().to_le_bytes());
            }
        }
        Digest::of(&bytes)
    }
}

/// Places the robots uniformly without overlap (with an index of them).
fn place_robots(
    w: &crate::config::WorldConfig,
    arena: &Arena,
    rng: &mut Rng,
) -> Result<(Vec<Pose>, RobotGrid), WorldError> {
    let r = w.robot_radius_m;
    let lim = arena.half_side_m - r;
    // Flow-FL's foragers start in their nest (`foraging_batch.argos`, `<distribute>`).
    let starts_in_nest = |i: u32| {
        w.foraging.rule == ForagingRule::Flowfl
            && match w.behaviour {
                Behaviour::Foraging => true,
                Behaviour::Mixed => w.mixed.behaviour_of(i, w.robots) == Behaviour::Foraging,
                Behaviour::Avoidance | Behaviour::Flocking => false,
            }
    };
    let mut poses: Vec<Pose> = Vec::with_capacity(w.robots as usize);
    let mut grid = RobotGrid::default();
    grid.rebuild(&arena.grid, &poses);
    for i in 0..w.robots {
        let what = || format!("robot {} of {} (a disk of radius {r} m)", i + 1, w.robots);
        if lim < 0.0 {
            return Err(WorldError::Placement {
                what: what(),
                why: format!(
                    "it is larger than the arena (world.arena_side_m = {})",
                    w.arena_side_m
                ),
            });
        }
        let x_max = if starts_in_nest(i) {
            foraging_flowfl::NEST_EDGE_X_M.min(lim)
        } else {
            lim
        };
        let mut placed = None;
        for _ in 0..arena::PLACEMENT_ATTEMPTS {
            let (x, y) = (rng.range(-lim, x_max), rng.range(-lim, lim));
            if !physics::blocked(arena, &grid, &poses, r, u32::MAX, x, y) {
                placed = Some((x, y));
                break;
            }
        }
        let Some((x, y)) = placed else {
            return Err(WorldError::Placement {
                what: what(),
                why: format!(
                    "no spot free of walls, obstacles and robots after {} attempts: world.robots = {} \
                     do not fit in world.arena_side_m = {} with world.cylinders = {} and world.boxes = {}; \
                     use fewer robots or obstacles or a larger arena",
                    arena::PLACEMENT_ATTEMPTS,
                    w.robots,
                    w.arena_side_m,
                    w.cylinders,
                    w.boxes
                ),
            });
        };
        let theta = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
        grid.push(&arena.grid, x, y);
        poses.push(Pose { x, y, theta });
    }
    Ok((poses, grid))
}

/// The held-out set: an observer copy of the world (same obstacles, robots placed and driven
/// from a seed derived with `Purpose::Heldout`) in which a ground-truth observer records
/// `data.heldout_samples` trajectories in windows spread evenly over the whole run, so that
/// the held-out set is drawn from the same stretch of time as the robots' training data (a set
/// taken from the first minutes only would measure the start of the run, when robots have just
/// been placed). [`HeldoutPlan`] says which windows and which robots.
fn heldout_set(config: &Config, seed: u64) -> Result<Vec<Sample>, WorldError> {
    let wanted = config.data.heldout_samples as usize;
    if wanted == 0 {
        return Ok(Vec::new());
    }
    let derived = rng::stream(seed, Purpose::Heldout, 0).next_u64();
    let mut copy = World::build(config, seed, derived, false)?;
    let mut controllers = Controllers::new(config, derived);
    let rec = Recording::new(&config.data);
    let n = copy.poses.len();
    let plan = HeldoutPlan::new(
        wanted,
        n,
        config.data.heldout_windows as usize,
        config.ticks(),
        rec.trajectory_ticks,
    );
    let mut observer = HeldoutObserver::new(rec, plan.per_window, wanted);
    let window_ticks = u64::from(rec.trajectory_ticks);
    let last_tick = plan.starts.last().map_or(0, |s| s + window_ticks);
    let mut next = 0;
    for tick in 0..last_tick {
        let event = controllers.decide(&copy);
        copy.apply(&event);
        // Tick `tick` moves the world to time `tick + 1`; a window observes the positions after
        // each of its ticks.
        let Some(&start) = plan.starts.get(next) else {
            break;
        };
        if tick >= start {
            let poses = &copy.poses;
            observer.observe(
                copy.time(),
                (0..plan.per_window).map(|i| {
                    let p = &poses[plan.robot(next, i)];
                    [p.x as f32, p.y as f32]
                }),
            );
            if tick + 1 == start + window_ticks {
                next += 1;
            }
        }
    }
    assert!(
        observer.done(),
        "the held-out observer has a sample per robot and window"
    );
    Ok(observer.into_samples())
}

/// Which windows and robots the held-out observer records (`data.heldout_windows`, W):
/// - when the swarm is too small to fill W windows (`ceil(wanted / robots) >= W`, 15 robots
///   and fewer at the paper's 200 samples), or W = 0: `ceil(wanted / robots)` windows of every
///   robot, the last one partial (the set as it was before the key);
/// - otherwise W windows of `k = min(ceil(wanted / W), robots)` robots each: in window `w`,
///   robot `floor((i W + w) N / (k W))` for `i = 0..k`, so the W k observations are spread
///   evenly over the swarm's N robots (each window its own, distinct robots, ascending).
///
/// So the set's weight in windows, the noise of a final value, is the same at every size
/// above the paper's, and 15 robots keep their set byte for byte.
#[derive(Clone, Debug, PartialEq, Eq)]
struct HeldoutPlan {
    /// The first tick of each window ([`heldout_window_starts`]).
    starts: Vec<u64>,
    /// Robots observed per window.
    per_window: usize,
    robots: usize,
}

impl HeldoutPlan {
    fn new(
        wanted: usize,
        robots: usize,
        windows: usize,
        run_ticks: u64,
        window_ticks: u32,
    ) -> HeldoutPlan {
        let robots = robots.max(1);
        let every_robot = wanted.div_ceil(robots);
        let (count, per_window) = if windows == 0 || every_robot >= windows {
            (every_robot, robots)
        } else {
            (windows, wanted.div_ceil(windows).min(robots))
        };
        HeldoutPlan {
            starts: heldout_window_starts(count as u64, run_ticks, window_ticks),
            per_window,
            robots,
        }
    }

    /// The robot observed in slot `i` of window `w`.
    fn robot(&self, w: usize, i: usize) -> usize {
        let windows = self.starts.len() as u128;
        let slot = i as u128 * windows + w as u128;
        (slot * self.robots as u128 / (self.per_window as u128 * windows)) as usize
    }
}

/// The first tick of each of `windows` held-out observation windows of `window_ticks` ticks,
/// each centered in its equal share of the run's `run_ticks`. When the run is too short for the
/// windows to be apart, they follow each other from tick 0.
fn heldout_window_starts(windows: u64, run_ticks: u64, window_ticks: u32) -> Vec<u64> {
    let windows = windows.max(1);
    let window_ticks = u64::from(window_ticks);
    let share = run_ticks / windows;
    if share <= window_ticks {
        return (0..windows).map(|k| k * window_ticks).collect();
    }
    let margin = (share - window_ticks) / 2;
    (0..windows).map(|k| k * share + margin).collect()
}

/// Two independent normal draws times `sigma` (Box-Muller, both branches, `libm` only).
fn gaussian_pair(rng: &mut Rng, sigma: f64) -> (f64, f64) {
    let u1 = 1.0 - rng.uniform();
    let u2 = rng.uniform();
    let radius = sigma * libm::sqrt(-2.0 * libm::log(u1));
    let (s, c) = libm::sincos(2.0 * std::f64::consts::PI * u2);
    (radius * c, radius * s)
}

fn mix_in(state: u64, word: u64) -> u64 {
    (state ^ word)
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .rotate_left(29)
        ^ (state >> 7)
}

fn chain_sample(prev: &Digest, robot: RobotId, s: &Sample) -> Digest {
    let mut bytes = Vec::with_capacity(44 + 8 * s.points.len());
    bytes.extend_from_slice(&prev.0);
    bytes.extend_from_slice(&robot.to_le_bytes());
    bytes.extend_from_slice(&s.time.0.to_le_bytes());
    for p in &s.points {
        bytes.extend_from_slice(&p[0].to_bits().to_le_bytes());
        bytes.extend_from_slice(&p[1].to_bits().to_le_bytes());
    }
    Digest::of(&bytes)
}

#[cfg(test)]
mod tests;

//! The world: arena, robots, physics, sensing and trajectory data (SPEC.md section 1).
//!
//! Placeholder with the final interface: robots drive straight and turn back at the walls. The
//! world issue replaces the bodies (obstacles, proximity sensors, range-and-bearing, data)
//! while keeping these signatures. [`World`] is the reduced state (folded by [`World::apply`]);
//! [`Controllers`] is the driver-side decision maker whose choices become [`TickEvent`]s.

use serde::{Deserialize, Serialize};

use crate::config::Config;
use crate::data::Sample;
use crate::types::{Digest, RobotId, SimTime};

/// What can go wrong building a world.
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
}

/// Wheel speeds of one robot for one tick, in m/s.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WheelCommand {
    /// Left wheel speed.
    pub left: f32,
    /// Right wheel speed.
    pub right: f32,
}

/// One tick of the world: every robot's wheel command, in robot order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TickEvent {
    /// One command per robot.
    pub commands: Vec<WheelCommand>,
}

/// A robot's pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// x in metres.
    pub x: f64,
    /// y in metres.
    pub y: f64,
    /// Heading in radians.
    pub theta: f64,
}

/// Summary figures of the world, for `summary.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorldStats {
    /// Interpenetrations detected (must be 0).
    pub collisions: u64,
    /// Mean number of robots in range per robot and tick.
    pub mean_neighbours: f64,
    /// Samples collected per robot per 600 s: mean over robots.
    pub samples_per_robot_per_600s: f64,
    /// Standard deviation over robots of the above.
    pub samples_per_robot_per_600s_std: f64,
    /// Partial trajectories discarded because a tick was missed.
    pub trajectories_discarded: u64,
}

/// The reduced state of the world.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct World {
    tick: u64,
    tick_ms: u64,
    half_side_m: f64,
    poses: Vec<Pose>,
    peers: Vec<Vec<RobotId>>,
    range_m: f64,
}

impl World {
    /// The world at time 0 of the run seeded with `seed`.
    pub fn new(config: &Config, seed: u64) -> Result<World, WorldError> {
        let n = config.world.robots as usize;
        let mut rng = crate::rng::stream(seed, crate::rng::Purpose::Placement, 0);
        let half = config.world.arena_side_m / 2.0 - 0.1;
        let poses = (0..n)
            .map(|_| Pose {
                x: rng.range(-half, half),
                y: rng.range(-half, half),
                theta: rng.range(-std::f64::consts::PI, std::f64::consts::PI),
            })
            .collect();
        let mut world = World {
            tick: 0,
            tick_ms: (config.run.tick_s * 1000.0).round() as u64,
            half_side_m: config.world.arena_side_m / 2.0,
            poses,
            peers: vec![Vec::new(); n],
            range_m: config.world.rab_range_m,
        };
        world.refresh_peers();
        Ok(world)
    }

    /// Folds one tick.
    pub fn apply(&mut self, event: &TickEvent) {
        assert_eq!(event.commands.len(), self.poses.len(), "one command per robot");
        let dt = self.tick_ms as f64 / 1000.0;
        for (pose, cmd) in self.poses.iter_mut().zip(&event.commands) {
            let v = 0.5 * (f64::from(cmd.left) + f64::from(cmd.right));
            let w = (f64::from(cmd.right) - f64::from(cmd.left)) / 0.053;
            pose.theta += w * dt;
            pose.x = (pose.x + v * libm::cos(pose.theta) * dt).clamp(-self.half_side_m, self.half_side_m);
            pose.y = (pose.y + v * libm::sin(pose.theta) * dt).clamp(-self.half_side_m, self.half_side_m);
        }
        self.tick += 1;
        if self.tick % 5 == 0 {
            self.refresh_peers();
        }
    }

    fn refresh_peers(&mut self) {
        let n = self.poses.len();
        for i in 0..n {
            self.peers[i] = (0..n)
                .filter(|&j| j != i && {
                    let (a, b) = (self.poses[i], self.poses[j]);
                    (a.x - b.x).powi(2) + (a.y - b.y).powi(2) <= self.range_m * self.range_m
                })
                .map(|j| j as RobotId)
                .collect();
        }
    }

    /// Simulated time of the state.
    pub fn time(&self) -> SimTime {
        SimTime(self.tick * self.tick_ms)
    }

    /// Robot poses, in robot order.
    pub fn poses(&self) -> &[Pose] {
        &self.poses
    }

    /// The robot's current peer set (robots in radio range), ascending.
    pub fn peers(&self, robot: RobotId) -> &[RobotId] {
        &self.peers[robot as usize]
    }

    /// The robot's current data set (unexpired samples, oldest first).
    pub fn dataset(&self, robot: RobotId) -> Vec<Sample> {
        let _ = robot;
        Vec::new()
    }

    /// The fixed held-out set of noise-free samples.
    pub fn heldout(&self) -> &[Sample] {
        &[]
    }

    /// Summary figures so far.
    pub fn stats(&self) -> WorldStats {
        WorldStats::default()
    }

    /// A digest of the whole state.
    pub fn digest(&self) -> Digest {
        Digest::of(&rmp_serde::to_vec(self).expect("world serialises"))
    }
}

/// The robots' controllers: driver-side state (random-walk timers, their random streams).
#[derive(Clone, Debug)]
pub struct Controllers {
    speed: f32,
    half_side_m: f64,
}

impl Controllers {
    /// Controllers for the run seeded with `seed`.
    pub fn new(config: &Config, seed: u64) -> Controllers {
        let _ = seed;
        Controllers {
            speed: config.world.cruise_speed_mps as f32,
            half_side_m: config.world.arena_side_m / 2.0,
        }
    }

    /// Decides every robot's wheel command for the next tick.
    pub fn decide(&mut self, world: &World) -> TickEvent {
        let edge = self.half_side_m - 0.05;
        TickEvent {
            commands: world
                .poses()
                .iter()
                .map(|p| {
                    if p.x.abs() > edge || p.y.abs() > edge {
                        WheelCommand { left: -self.speed, right: self.speed }
                    } else {
                        WheelCommand { left: self.speed, right: self.speed }
                    }
                })
                .collect(),
        }
    }
}

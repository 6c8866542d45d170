//! The robots' controllers. This file holds the default behaviour, the avoidance walk: a random
//! walk at cruise speed with Braitenberg-style obstacle avoidance on the IR proximity sensors
//! (docs/SPEC.md section 1; its moves are in `steering.rs`, shared with the other behaviours),
//! and [`Controllers`], which runs each robot's behaviour (`flocking.rs`, `foraging.rs`,
//! `foraging_flowfl.rs`; `behaviour.rs` says which robot runs which). It runs on the driver
//! side: its decisions become [`TickEvent`]s that the physics reducer folds; its state is not
//! part of the [`World`].
//!
//! Per robot and tick, in this order:
//! 1. If a front sensor (one pointing less than 90 degrees off the heading) reads above
//!    `proximity_threshold`, the robot turns in place away from the obstacle: clockwise when
//!    the readings weighted by the sine of their angle lean left, counter-clockwise when they
//!    lean right, the last avoidance direction on a tie. It keeps that direction until the
//!    front is clear (so it does not dither in corners). Any random turn is cancelled.
//! 2. Else, during a random turn, it turns in place.
//! 3. Else, with probability `random_turn_rate_per_s * tick_s`, it starts a random turn of
//!    uniform duration in [0, `random_turn_max_s`] in a random direction; otherwise it drives
//!    straight at `cruise_speed_mps`.
//!
//! With `world.avoidance = "epuck"`, step 1 is the paper's code instead (`epuck.rs`): when any
//! sensor reads above the threshold, the wheel speeds its weighted readings give (any random
//! turn is cancelled); steps 2 and 3 stay. With `"khepera"` (the `flowfl` preset), step 1 is
//! Flow-FL's pivot on one wheel (`khepera.rs`) the same way. The steering behaviours
//! (flocking, foraging) keep their turn, on the readings of the chosen ring.
//!
//! With home ranges (`world.home_range.alpha` finite, `home_range.rs`), steps 2 and 3 apply
//! only inside the robot's current region: outside it, once the front is clear, the robot
//! heads for the region's centre (`steering::pull`), driving straight for 2 s after each
//! avoidance move so it rounds the obstacle. Step 1 (avoidance) keeps priority.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::home_range::HomeRanges;
use super::steering::{
    avoid, hold_after_avoiding, override_walk, pull, walk, RobotController, Steer, Walk,
    WheelCommand,
};
use super::{
    behaviour, epuck, flocking, foraging, foraging_flowfl, khepera, place, sensor_angle, Workers,
    World,
};
use crate::config::{Avoidance, Behaviour, Config, FlockingConfig, MixedAssign};
use crate::rng::{self, Purpose};

/// One tick of the world: every robot's wheel command, in robot order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TickEvent {
    /// One command per robot.
    pub commands: Vec<WheelCommand>,
}

/// The robots' controllers: driver-side state (random-walk timers, their random streams).
#[derive(Clone, Debug)]
pub struct Controllers {
    cruise_mmps: i16,
    /// `world.avoidance`: `epuck` and `khepera` replace the avoidance turn by their rule.
    rule: Avoidance,
    threshold: f64,
    walk: Walk,
    /// For each sensor, whether it faces forward and the sine of its angle.
    sensors: Vec<(bool, f64)>,
    robots: Vec<RobotController>,
    readings: Vec<f64>,
    flocking: FlockingConfig,
    /// Reused buffer: the range-and-bearing contacts flockers read.
    contacts: Vec<Vec<crate::types::RobotId>>,
    /// Flow-FL's foragers' turning states and last commands (`foraging_flowfl.rs`).
    flowfl: Vec<foraging_flowfl::Wheels>,
    /// The avoidance walk's home ranges, when `world.home_range` is on.
    home: Option<HomeRanges>,
}

impl Controllers {
    /// Controllers for the run seeded with `seed` (streams `Purpose::Controller`, per robot).
    pub fn new(config: &Config, seed: u64) -> Controllers {
        let w = &config.world;
        let n = w.proximity_sensors.max(1);
        let sensors = (0..n)
            .map(|k| {
                let a = sensor_angle(w.avoidance, k, n);
                (libm::cos(a) > 1e-9, libm::sin(a))
            })
            .collect();
        let robots = (0..w.robots)
            .map(|i| RobotController::new(rng::stream(seed, Purpose::Controller, i)))
            .collect();
        Controllers {
            cruise_mmps: WheelCommand::from_mps(w.cruise_speed_mps, 0.0).left_mmps,
            rule: w.avoidance,
            threshold: w.proximity_threshold,
            walk: Walk {
                turn_probability: (w.random_turn_rate_per_s * config.run.tick_s).min(1.0),
                turn_max_s: w.random_turn_max_s,
                tick_s: config.run.tick_s,
            },
            sensors,
            robots,
            readings: vec![0.0; n as usize],
            flocking: w.flocking.clone(),
            contacts: Vec::new(),
            flowfl: vec![foraging_flowfl::Wheels::default(); w.robots as usize],
            home: HomeRanges::new(&w.home_range, w.arena_side_m, w.robots, seed),
        }
    }

    /// Decides every robot's wheel command for the next tick from the current state. A large
    /// swarm decides on the process's world threads ([`Workers::default_pool`]).
    pub fn decide(&mut self, world: &World) -> TickEvent {
        self.decide_on(world, Workers::default_pool())
    }

    /// [`Controllers::decide`] on `workers`: each robot's decision reads the world and changes
    /// only its own controller, so robots decide in parallel, in robot order in the event (the
    /// same bits on every number of threads).
    pub fn decide_on(&mut self, world: &World, workers: Workers<'_>) -> TickEvent {
        assert_eq!(
            world.poses().len(),
            self.robots.len(),
            "controllers built for another swarm"
        );
        let behaviours = world.behaviours();
        if behaviours.is_some_and(|b| b.of.contains(&Behaviour::Flocking)) {
            world.contacts(&mut self.contacts);
        }
        let mut robots = std::mem::take(&mut self.robots);
        let mut flowfl = std::mem::take(&mut self.flowfl);
        let mut readings = std::mem::take(&mut self.readings);
        let shared = &*self;
        let commands = match workers.for_robots(robots.len()) {
            None => robots
                .iter_mut()
                .zip(flowfl.iter_mut())
                .enumerate()
                .map(|(i, (c, f))| shared.decide_one(world, i, c, f, &mut readings))
                .collect(),
            Some(pool) => pool.install(|| {
                let sensors = readings.len();
                robots
                    .par_iter_mut()
                    .zip(flowfl.par_iter_mut())
                    .enumerate()
                    .with_min_len(super::par::PIECE)
                    .map_init(
                        || vec![0.0; sensors],
                        |readings, (i, (c, f))| shared.decide_one(world, i, c, f, readings),
                    )
                    .collect()
            }),
        };
        self.robots = robots;
        self.flowfl = flowfl;
        self.readings = readings;
        TickEvent { commands }
    }

    /// Robot `i`'s wheel command: `c` and `flowfl` are its controller and its Flow-FL wheels,
    /// `readings` a buffer for its proximity readings.
    fn decide_one(
        &self,
        world: &World,
        i: usize,
        c: &mut RobotController,
        flowfl: &mut foraging_flowfl::Wheels,
        readings: &mut [f64],
    ) -> WheelCommand {
        let v = self.cruise_mmps;
        // Each robot's behaviour this tick is the world's (`behaviour.rs`): fixed per robot,
        // or, under the place rule, where the robot stands (`place.rs`).
        let behaviours = world.behaviours();
        let behaviour_of = |i: usize| behaviours.map_or(Behaviour::Avoidance, |b| b.of[i]);
        let by_place = behaviours.is_some_and(|b| b.assign == MixedAssign::Place);
        world.proximity(i as u32, readings);
        let mut front_max = 0.0f64;
        let mut lean = 0.0;
        for (&(front, sin), &r) in self.sensors.iter().zip(readings.iter()) {
            if front {
                front_max = front_max.max(r);
                lean += r * sin;
            }
        }
        let blocked = front_max > self.threshold;
        let steer = Steer {
            blocked,
            lean,
            cruise_mmps: v,
        };
        let walk_params = self.walk;
        let cruise_mps = f64::from(v) / 1000.0;
        let ruled = match self.rule {
            Avoidance::Turn => None,
            Avoidance::Epuck => epuck::avoid(readings, self.threshold, cruise_mps),
            Avoidance::Khepera => khepera::avoid(readings, self.threshold, cruise_mps),
        };
        let turn = self.rule == Avoidance::Turn;
        let pose = world.poses()[i];
        // With home ranges: the centre of the robot's current region, if it is outside.
        let home = self.home.as_ref().and_then(|h| {
            let region = h.current(i as u32, world.time().0);
            (h.region_of(pose.x, pose.y) != region).then(|| h.centre(region))
        });
        let pulled = self.home.is_some();
        let avoidance = |c: &mut RobotController| {
            let command = match ruled {
                Some((left, right)) => override_walk(c, WheelCommand::from_mps(left, right)),
                None if blocked && turn => avoid(c, lean, v),
                None => {
                    return match home {
                        Some(centre) => pull(c, pose, (centre.0 - pose.x, centre.1 - pose.y), v),
                        None => walk(c, &walk_params, v),
                    }
                }
            };
            if pulled {
                hold_after_avoiding(c);
            }
            command
        };
        match (behaviour_of(i), behaviours) {
            (Behaviour::Flocking, _) => {
                let goal = if by_place {
                    place::flocking_goal(pose.x)
                } else {
                    flocking::goal(&self.flocking, world.time().secs())
                };
                flocking::command(
                    c,
                    &steer,
                    i,
                    world.poses(),
                    &self.contacts[i],
                    &self.flocking,
                    goal,
                )
            }
            (
                Behaviour::Foraging,
                Some(behaviour::Behaviours {
                    flowfl: Some(f), ..
                }),
            ) => foraging_flowfl::command(
                flowfl,
                f.robots[i].drive,
                pose,
                self.rule,
                readings,
                cruise_mps,
            ),
            (Behaviour::Foraging, Some(b)) => {
                foraging::command(c, b.foragers[i], pose, b, &steer, avoidance)
            }
            _ => avoidance(c),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tick_event_of_fifteen_robots_is_small() {
        let ev = TickEvent {
            commands: (0..15)
                .map(|i| {
                    if i % 3 == 0 {
                        WheelCommand::from_mps(-0.025, 0.025)
                    } else {
                        WheelCommand::from_mps(0.025, 0.025)
                    }
                })
                .collect(),
        };
        let bytes = rmp_serde::to_vec(&ev).unwrap();
        assert!(bytes.len() <= 60, "{} bytes", bytes.len());
        assert_eq!(rmp_serde::from_slice::<TickEvent>(&bytes).unwrap(), ev);
    }
}

//! The robots' controllers. This file holds the default behaviour, the avoidance walk: a random
//! walk at cruise speed with Braitenberg-style obstacle avoidance on the IR proximity sensors
//! (docs/SPEC.md section 1), the steering shared by the other behaviours, and [`Controllers`],
//! which runs each robot's behaviour (`flocking.rs`, `foraging.rs`; `behaviour.rs` says
//! which robot runs which). It runs on the driver side: its decisions become [`TickEvent`]s
//! that the physics reducer folds; its state is not part of the [`World`].
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

use serde::{Deserialize, Serialize};

use super::World;
use crate::config::{Behaviour, Config, FlockingConfig};
use crate::rng::{self, Purpose, Rng};

/// Wheel speeds of one robot for one tick, quantised to millimetres per second (so that the
/// per-tick event stays a few bytes per robot in the log).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct WheelCommand {
    /// Left wheel speed in mm/s.
    pub left_mmps: i16,
    /// Right wheel speed in mm/s.
    pub right_mmps: i16,
}

impl WheelCommand {
    /// The command closest to the given speeds in m/s (saturating at +-32.767 m/s).
    pub fn from_mps(left: f64, right: f64) -> WheelCommand {
        WheelCommand {
            left_mmps: quantise(left),
            right_mmps: quantise(right),
        }
    }

    /// Left wheel speed in m/s.
    pub fn left_mps(self) -> f64 {
        f64::from(self.left_mmps) / 1000.0
    }

    /// Right wheel speed in m/s.
    pub fn right_mps(self) -> f64 {
        f64::from(self.right_mmps) / 1000.0
    }
}

fn quantise(v: f64) -> i16 {
    let mm = (v * 1000.0).round();
    if mm.is_nan() {
        0
    } else {
        mm.clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
    }
}

/// One tick of the world: every robot's wheel command, in robot order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TickEvent {
    /// One command per robot.
    pub commands: Vec<WheelCommand>,
}

/// One robot's controller state (driver side).
#[derive(Clone, Debug)]
pub(super) struct RobotController {
    rng: Rng,
    /// Ticks left in the current random turn.
    turn_ticks: u32,
    /// Direction of the random turn: +1 counter-clockwise, -1 clockwise.
    turn_dir: i8,
    /// Direction of the avoidance turn in progress, if any.
    pub(super) avoiding: Option<i8>,
    /// Direction of the last avoidance turn (used on ties).
    last_avoid_dir: i8,
    /// Steering behaviours only: ticks left driving straight after an avoidance turn.
    straight_ticks: u32,
}

/// Ticks a steering robot (flocking, a returning forager) drives straight after an avoidance
/// turn before it steers again (2 s at 10 Hz), so it rounds an obstacle instead of turning
/// straight back into it.
pub(super) const HOLD_TICKS: u32 = 20;

/// What a robot's sensors say this tick, for the steering behaviours.
#[derive(Clone, Copy, Debug)]
pub(super) struct Steer {
    /// A front proximity reading exceeds the threshold.
    pub(super) blocked: bool,
    /// The front readings weighted by the sine of their angle (> 0: the obstacle is left).
    pub(super) lean: f64,
    /// Cruise speed in mm/s.
    pub(super) cruise_mmps: i16,
}

fn spin(v: i16, dir: i8) -> WheelCommand {
    if dir > 0 {
        WheelCommand {
            left_mmps: -v,
            right_mmps: v,
        }
    } else {
        WheelCommand {
            left_mmps: v,
            right_mmps: -v,
        }
    }
}

/// The avoidance turn: away from the side the obstacle leans to, keeping the direction of a
/// turn in progress; cancels any random turn.
fn avoid(c: &mut RobotController, lean: f64, v: i16) -> WheelCommand {
    c.turn_ticks = 0;
    let dir = match c.avoiding {
        Some(d) => d,
        None if lean > 0.0 => -1,
        None if lean < 0.0 => 1,
        None => c.last_avoid_dir,
    };
    c.avoiding = Some(dir);
    c.last_avoid_dir = dir;
    spin(v, dir)
}

/// The steering behaviours' move toward the world-frame vector `to`: avoid an obstacle in
/// front; else hold straight after an avoidance; else turn in place when the target is more
/// than 90 degrees off the heading, and otherwise drive with the inner wheel slowed in
/// proportion to the angle (straight when aligned).
pub(super) fn steer_to(
    c: &mut RobotController,
    s: &Steer,
    pose: super::Pose,
    to: (f64, f64),
) -> WheelCommand {
    let v = s.cruise_mmps;
    if s.blocked {
        c.straight_ticks = HOLD_TICKS;
        return avoid(c, s.lean, v);
    }
    c.avoiding = None;
    let straight = WheelCommand {
        left_mmps: v,
        right_mmps: v,
    };
    if c.straight_ticks > 0 {
        c.straight_ticks -= 1;
        return straight;
    }
    if to.0 * to.0 + to.1 * to.1 < 1e-12 {
        return straight;
    }
    let mut err = libm::atan2(to.1, to.0) - pose.theta;
    while err > std::f64::consts::PI {
        err -= 2.0 * std::f64::consts::PI;
    }
    while err < -std::f64::consts::PI {
        err += 2.0 * std::f64::consts::PI;
    }
    let half = std::f64::consts::FRAC_PI_2;
    if err.abs() > half {
        return spin(v, if err > 0.0 { 1 } else { -1 });
    }
    let inner = (f64::from(v) * (half - err.abs()) / half).round() as i16;
    if err > 0.0 {
        WheelCommand {
            left_mmps: inner,
            right_mmps: v,
        }
    } else {
        WheelCommand {
            left_mmps: v,
            right_mmps: inner,
        }
    }
}

/// The random walk's parameters.
#[derive(Clone, Copy, Debug)]
struct Walk {
    turn_probability: f64,
    turn_max_s: f64,
    tick_s: f64,
}

/// The avoidance walk without an obstacle in front: a random turn in progress, or with
/// probability `turn_probability` a new one, else straight.
fn walk(c: &mut RobotController, w: &Walk, v: i16) -> WheelCommand {
    let straight = WheelCommand {
        left_mmps: v,
        right_mmps: v,
    };
    c.avoiding = None;
    if c.turn_ticks > 0 {
        c.turn_ticks -= 1;
        spin(v, c.turn_dir)
    } else if c.rng.chance(w.turn_probability) {
        let ticks = (c.rng.uniform() * w.turn_max_s / w.tick_s).round() as u32;
        c.turn_dir = if c.rng.below(2) == 0 { 1 } else { -1 };
        if ticks > 0 {
            c.turn_ticks = ticks - 1;
            spin(v, c.turn_dir)
        } else {
            straight
        }
    } else {
        straight
    }
}

/// The robots' controllers: driver-side state (random-walk timers, their random streams).
#[derive(Clone, Debug)]
pub struct Controllers {
    cruise_mmps: i16,
    threshold: f64,
    walk: Walk,
    /// For each sensor, whether it faces forward and the sine of its angle.
    sensors: Vec<(bool, f64)>,
    robots: Vec<RobotController>,
    readings: Vec<f64>,
    /// Each robot's behaviour (`world/behaviour.rs`).
    behaviours: Vec<Behaviour>,
    flocking: FlockingConfig,
    /// Reused buffer: the range-and-bearing contacts flockers read.
    contacts: Vec<Vec<crate::types::RobotId>>,
}

impl Controllers {
    /// Controllers for the run seeded with `seed` (streams `Purpose::Controller`, per robot).
    pub fn new(config: &Config, seed: u64) -> Controllers {
        let w = &config.world;
        let n = w.proximity_sensors.max(1);
        let sensors = (0..n)
            .map(|k| {
                let a = 2.0 * std::f64::consts::PI * f64::from(k) / f64::from(n);
                (libm::cos(a) > 1e-9, libm::sin(a))
            })
            .collect();
        let robots = (0..w.robots)
            .map(|i| {
                let mut rng = rng::stream(seed, Purpose::Controller, i);
                let last_avoid_dir = if rng.below(2) == 0 { 1 } else { -1 };
                RobotController {
                    rng,
                    turn_ticks: 0,
                    turn_dir: 1,
                    avoiding: None,
                    last_avoid_dir,
                    straight_ticks: 0,
                }
            })
            .collect();
        Controllers {
            cruise_mmps: WheelCommand::from_mps(w.cruise_speed_mps, 0.0).left_mmps,
            threshold: w.proximity_threshold,
            walk: Walk {
                turn_probability: (w.random_turn_rate_per_s * config.run.tick_s).min(1.0),
                turn_max_s: w.random_turn_max_s,
                tick_s: config.run.tick_s,
            },
            sensors,
            robots,
            readings: vec![0.0; n as usize],
            behaviours: super::behaviour::assignment(config),
            flocking: w.flocking.clone(),
            contacts: Vec::new(),
        }
    }

    /// Decides every robot's wheel command for the next tick from the current state.
    pub fn decide(&mut self, world: &World) -> TickEvent {
        assert_eq!(
            world.poses().len(),
            self.robots.len(),
            "controllers built for another swarm"
        );
        let v = self.cruise_mmps;
        if self.behaviours.contains(&Behaviour::Flocking) {
            world.contacts(&mut self.contacts);
        }
        let mut commands = Vec::with_capacity(self.robots.len());
        for (i, c) in self.robots.iter_mut().enumerate() {
            world.proximity(i as u32, &mut self.readings);
            let mut front_max = 0.0f64;
            let mut lean = 0.0;
            for (&(front, sin), &r) in self.sensors.iter().zip(&self.readings) {
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
            let avoidance = |c: &mut RobotController| {
                if blocked {
                    avoid(c, lean, v)
                } else {
                    walk(c, &walk_params, v)
                }
            };
            let pose = world.poses()[i];
            let command = match (self.behaviours[i], world.behaviours()) {
                (Behaviour::Flocking, _) => super::flocking::command(
                    c,
                    &steer,
                    i,
                    world.poses(),
                    &self.contacts[i],
                    &self.flocking,
                    world.time().secs(),
                ),
                (Behaviour::Foraging, Some(b)) => {
                    super::foraging::command(c, b.foragers[i], pose, b, &steer, avoidance)
                }
                _ => avoidance(c),
            };
            commands.push(command);
        }
        TickEvent { commands }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wheel_commands_quantise_to_millimetres_per_second() {
        let c = WheelCommand::from_mps(0.025, -0.0254);
        assert_eq!((c.left_mmps, c.right_mmps), (25, -25));
        assert_eq!(c.left_mps(), 0.025);
        assert_eq!(
            WheelCommand::from_mps(1e9, f64::NAN),
            WheelCommand {
                left_mmps: i16::MAX,
                right_mmps: 0
            }
        );
    }

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

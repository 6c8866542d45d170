//! The steering every behaviour shares: the wheel command, one robot's controller state, the
//! avoidance turn, the random walk (the avoidance behaviour's whole rule, docs/SPEC.md
//! section 1), the steer toward a vector that flocking and returning foragers use, and the
//! home-range pull of the avoidance walk (`home_range.rs`). A leaf
//! of `world/`: `controller.rs`, `flocking.rs` and `foraging.rs` import it, it imports none of
//! them.

use serde::{Deserialize, Serialize};

use super::Pose;
use crate::rng::Rng;

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

/// One robot's controller state (driver side).
#[derive(Clone, Debug)]
pub(super) struct RobotController {
    /// The robot's own random stream (`Purpose::Controller`).
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

impl RobotController {
    /// A robot's controller at the start: no turn in progress, the tie direction drawn from
    /// its stream (the first draw, so every behaviour starts from the same stream position).
    pub(super) fn new(mut rng: Rng) -> RobotController {
        let last_avoid_dir = if rng.below(2) == 0 { 1 } else { -1 };
        RobotController {
            rng,
            turn_ticks: 0,
            turn_dir: 1,
            avoiding: None,
            last_avoid_dir,
            straight_ticks: 0,
        }
    }
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
pub(super) fn avoid(c: &mut RobotController, lean: f64, v: i16) -> WheelCommand {
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

/// A command decided elsewhere (`world.avoidance = "epuck"`'s rule) that, like the
/// avoidance turn, cancels any random turn.
pub(super) fn override_walk(c: &mut RobotController, command: WheelCommand) -> WheelCommand {
    c.turn_ticks = 0;
    c.avoiding = None;
    command
}

/// The steering behaviours' move toward the world-frame vector `to`: avoid an obstacle in
/// front; else hold straight after an avoidance; else turn in place when the target is more
/// than 90 degrees off the heading, and otherwise drive with the inner wheel slowed in
/// proportion to the angle (straight when aligned).
pub(super) fn steer_to(
    c: &mut RobotController,
    s: &Steer,
    pose: Pose,
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
    head_to(pose, to, v)
}

/// The home-range pull (`home_range.rs`): like [`steer_to`] once the front is clear (the
/// avoidance rule has already had its say this tick): hold straight after an avoidance, then
/// head for `to`; cancels any random turn.
pub(super) fn pull(c: &mut RobotController, pose: Pose, to: (f64, f64), v: i16) -> WheelCommand {
    c.turn_ticks = 0;
    c.avoiding = None;
    if c.straight_ticks > 0 {
        c.straight_ticks -= 1;
        return WheelCommand {
            left_mmps: v,
            right_mmps: v,
        };
    }
    head_to(pose, to, v)
}

/// After an avoidance move, a pulled robot (`pull`) drives straight [`HOLD_TICKS`] before it
/// heads for its region again, so it rounds the obstacle instead of turning back into it.
pub(super) fn hold_after_avoiding(c: &mut RobotController) {
    c.straight_ticks = HOLD_TICKS;
}

/// Turn in place when the world-frame vector `to` is more than 90 degrees off the heading,
/// otherwise drive with the inner wheel slowed in proportion to the angle (straight when
/// aligned or when `to` is null).
fn head_to(pose: Pose, to: (f64, f64), v: i16) -> WheelCommand {
    let straight = WheelCommand {
        left_mmps: v,
        right_mmps: v,
    };
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
pub(super) struct Walk {
    /// Probability of starting a random turn at a tick.
    pub(super) turn_probability: f64,
    /// Longest random turn in seconds.
    pub(super) turn_max_s: f64,
    /// The tick in seconds.
    pub(super) tick_s: f64,
}

/// The avoidance walk without an obstacle in front: a random turn in progress, or with
/// probability `turn_probability` a new one, else straight.
pub(super) fn walk(c: &mut RobotController, w: &Walk, v: i16) -> WheelCommand {
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
}

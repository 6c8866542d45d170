//! Foraging (Flow-FL's third behaviour; docs/SPEC.md section 1, "Behaviours"): robots shuttle
//! between food sources and the nest.
//!
//! States, changed by the reducer after each tick's physics from the robot's position alone
//! ([`advance`]), so that replay reproduces them and checkpoints cover them:
//! - `Explore`: the avoidance random walk; touching a food source (center within the source's
//!   radius plus the robot's) picks an item up: `Return`.
//! - `Return`: steer straight for the nest's center, with the same obstacle avoidance (after an
//!   avoidance turn the robot drives straight for `HOLD_TICKS` before steering again, so it
//!   rounds obstacles instead of turning back into them); entering the nest delivers the item:
//!   `Rest` for `world.foraging.rest_s`.
//! - `Rest`: the robot stands still in the nest; then `Explore` again.
//!
//! The controller side ([`command`]) reads the state from the world. The state type,
//! [`Forager`], lives in `behaviour.rs` with the rest of the behaviours' reduced state.

use super::behaviour::{Behaviours, Forager};
use super::steering::{steer_to, RobotController, Steer, WheelCommand};
use super::Pose;
use crate::config::Behaviour;

/// Moves every forager's state on after the tick that brought the world to `tick`.
pub(super) fn advance(b: &mut Behaviours, poses: &[Pose], radius_m: f64, tick: u64) {
    let Some(nest) = b.nest else {
        return;
    };
    for (i, &p) in poses.iter().enumerate().take(b.of.len()) {
        if b.of[i] != Behaviour::Foraging {
            continue;
        }
        b.foragers[i] = match b.foragers[i] {
            Forager::Explore if b.at_food(p.x, p.y, radius_m) => Forager::Return,
            Forager::Return if nest.contains(p.x, p.y) => {
                b.deliveries += 1;
                Forager::Rest {
                    until: tick + b.rest_ticks,
                }
            }
            Forager::Rest { until } if tick >= until => Forager::Explore,
            state => state,
        };
    }
}

/// The wheel command of forager `i` for the next tick. `walk` is the avoidance walk's command
/// (what an exploring forager does, computed by the caller with the same draws an avoidance
/// robot makes).
pub(super) fn command(
    c: &mut RobotController,
    state: Forager,
    pose: Pose,
    b: &Behaviours,
    steer: &Steer,
    walk: impl FnOnce(&mut RobotController) -> WheelCommand,
) -> WheelCommand {
    match (state, b.nest) {
        (Forager::Explore, _) | (_, None) => walk(c),
        (Forager::Return, Some(nest)) => {
            steer_to(c, steer, pose, (nest.x - pose.x, nest.y - pose.y))
        }
        (Forager::Rest { .. }, Some(_)) => {
            c.avoiding = None;
            WheelCommand::from_mps(0.0, 0.0)
        }
    }
}

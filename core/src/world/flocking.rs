//! Flocking (Flow-FL's second behaviour; docs/SPEC.md section 1, "Behaviours"): each robot
//! steers along the sum of three vectors computed from the range-and-bearing readings of the
//! neighbours it is in contact with this tick, plus a pull toward a goal.
//!
//! - Separation and cohesion: for each neighbour at distance `d` along the unit bearing `u`,
//!   the generalised Lennard-Jones term of Flow-FL's controller (exponent 2),
//!   `f(d) = -(t/d) ((t/d)^4 - (t/d)^2)` with `t = world.flocking.target_distance_m`: negative
//!   (repulsion) closer than `t`, positive (attraction) beyond; the mean of `f(d) u` over the
//!   neighbours, clamped to length 1, weighted by `cohesion_weight`.
//! - Alignment: the mean of the neighbours' unit heading vectors (length <= 1), weighted by
//!   `alignment_weight` (the heading travels in the range-and-bearing message).
//! - Goal: the unit vector to the goal (Flow-FL's light), weighted by `goal_weight`; every
//!   `goal_swap_s` seconds the goal moves to its mirror image through the arena's center, so
//!   the flock keeps crossing the arena (0 keeps it fixed, as Flow-FL's light). In a mixed
//!   swarm by place (`place.rs`) the goal is instead that of the band the robot flocks in.
//!
//! The robot steers along the sum with the shared steering (`steering::steer_to`): obstacle
//! avoidance first, then a turn proportional to the heading error. The controller reads the
//! neighbours' true offsets (the recorded data carries the noise; steering does not need it).

use super::steering::{steer_to, RobotController, Steer, WheelCommand};
use super::Pose;
use crate::config::FlockingConfig;
use crate::types::RobotId;

/// The goal at time `t_s`.
pub fn goal(f: &FlockingConfig, t_s: f64) -> (f64, f64) {
    let swapped = f.goal_swap_s > 0.0 && ((t_s / f.goal_swap_s) as u64) % 2 == 1;
    if swapped {
        (-f.goal_x_m, -f.goal_y_m)
    } else {
        (f.goal_x_m, f.goal_y_m)
    }
}

/// The flocking robot `i`'s wheel command for the next tick, pulled toward `goal` (in metres:
/// [`goal`] at the time, or the place rule's, `place.rs`).
pub(super) fn command(
    c: &mut RobotController,
    steer: &Steer,
    i: usize,
    poses: &[Pose],
    neighbours: &[RobotId],
    f: &FlockingConfig,
    goal: (f64, f64),
) -> WheelCommand {
    let p = poses[i];
    let (mut cx, mut cy, mut ax, mut ay) = (0.0, 0.0, 0.0, 0.0);
    for &j in neighbours {
        let q = poses[j as usize];
        let (dx, dy) = (q.x - p.x, q.y - p.y);
        let d = libm::hypot(dx, dy).max(1e-6);
        let n = f.target_distance_m / d;
        let lj = -n * (n * n * n * n - n * n);
        cx += lj * dx / d;
        cy += lj * dy / d;
        ax += libm::cos(q.theta);
        ay += libm::sin(q.theta);
    }
    if !neighbours.is_empty() {
        let k = neighbours.len() as f64;
        (cx, cy, ax, ay) = (cx / k, cy / k, ax / k, ay / k);
        let len = libm::hypot(cx, cy);
        if len > 1.0 {
            (cx, cy) = (cx / len, cy / len);
        }
    }
    let (gx, gy) = goal;
    let (tx, ty) = (gx - p.x, gy - p.y);
    let gl = libm::hypot(tx, ty);
    let (ux, uy) = if gl > 1e-9 {
        (tx / gl, ty / gl)
    } else {
        (0.0, 0.0)
    };
    let to = (
        f.goal_weight * ux + f.cohesion_weight * cx + f.alignment_weight * ax,
        f.goal_weight * uy + f.cohesion_weight * cy + f.alignment_weight * ay,
    );
    steer_to(c, steer, p, to)
}

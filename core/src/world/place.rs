//! A mixed swarm by place (`world.mixed.assign = "place"`, the `flowfl-mixed` preset): Flow-FL's
//! `mixed_by_location` experiment, where a robot's behaviour is not its own but that of the
//! region it stands in (docs/SPEC.md section 1, "Behaviours").
//!
//! Flow-FL's controller (NESTLab/TrajectoryCollection, `argos-scripts/controllers/khepera_mixed/
//! khepera_mixed.cpp`, `CKheperaMixed::ControlStep`) reads the robot's position every tick and:
//! - flocks where x < -2 m or x > 2 m (`FLOCKING_1`, `FLOCKING_2`), toward a goal that depends
//!   on the side (`VectorToGoal`): (-0.95, -2.5) in the west band, (1.05, 2.5) in the east band,
//!   both on the south and north walls' side and outside the band, so flockers are drawn out of
//!   it, the west ones into the foraging region, the east ones into the avoidance region;
//! - else runs the obstacle avoidance ("diffusing") where y > 0 m (`DIFFUSION_Y`);
//! - else forages: one step of its foraging state machine (`Rest`, `Explore`,
//!   `ReturnToNest`). Outside the foraging region that state machine is not stepped at all: a
//!   robot keeps its foraging state, frozen, until it comes back. [`assign`] followed by
//!   `foraging::advance` (which steps only the robots whose behaviour is `Foraging` this tick)
//!   does the same here.
//!
//! The comparisons are Flow-FL's, strict, on the robot's center; at a boundary the behaviour
//! of the side named last wins (x = 2 m is not flocking, y = 0 m is foraging). The behaviour
//! is a pure function of the position, which is reduced state, so replaying the tick events
//! reproduces every assignment; the world's digest covers the assignment as well
//! (`World::digest`), and the forager states it freezes.
//!
//! Not reproduced: Flow-FL's loop functions (`mixed_loop_functions.cpp`, `PreStep`) let any
//! robot, whatever it is doing, pick an item up by driving over it and drop it in the nest
//! strip x < -1 m; our `simple` foragers' sources never run out, so only a forager that
//! touches one starts returning. The thresholds are Flow-FL's metres, not scaled with the
//! arena: `config/validate.rs` refuses an arena that cannot hold the goals.

use super::Pose;
use crate::config::Behaviour;

/// Flockers are the robots beyond this |x|, in metres (`FLOCKING_1 = -2`, `FLOCKING_2 = 2`).
pub const FLOCKING_BEYOND_X_M: f64 = 2.0;

/// Of the others, the robots above this y run obstacle avoidance, in metres (`DIFFUSION_Y`).
pub const AVOIDANCE_ABOVE_Y_M: f64 = 0.0;

/// The goal of the flockers in the west band, x < -2 m (`FLOCKING_GOAL_1`; a light there).
pub const WEST_GOAL_M: (f64, f64) = (-0.95, -2.5);

/// The goal of the flockers in the east band, x > 2 m (`FLOCKING_GOAL_2`; a light there).
pub const EAST_GOAL_M: (f64, f64) = (1.05, 2.5);

/// The behaviour of a robot whose center is at (`x`, `y`), in metres.
pub fn behaviour_at(x: f64, y: f64) -> Behaviour {
    // Flow-FL's `x < FLOCKING_1 or x > FLOCKING_2`, its thresholds being opposite.
    if x.abs() > FLOCKING_BEYOND_X_M {
        Behaviour::Flocking
    } else if y > AVOIDANCE_ABOVE_Y_M {
        Behaviour::Avoidance
    } else {
        Behaviour::Foraging
    }
}

/// The goal a flocker at `x` steers to: the west band's for x < 0, the east band's otherwise
/// (Flow-FL's `VectorToGoal` tests the same thresholds as the rule; between them, where a
/// robot does not flock, its goal is never read).
pub fn flocking_goal(x: f64) -> (f64, f64) {
    if x < 0.0 {
        WEST_GOAL_M
    } else {
        EAST_GOAL_M
    }
}

/// Sets every robot's behaviour from its current position.
pub(super) fn assign(of: &mut [Behaviour], poses: &[Pose]) {
    assert_eq!(of.len(), poses.len(), "one behaviour per robot");
    for (b, p) in of.iter_mut().zip(poses) {
        *b = behaviour_at(p.x, p.y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PLACE_LAYOUT_HALF_M;

    fn check(x: f64, y: f64, expect: Behaviour) {
        assert_eq!(behaviour_at(x, y), expect, "at ({x}, {y})");
    }

    #[test]
    fn the_regions_are_flow_fl_s() {
        use Behaviour::*;
        // The bands beyond |x| = 2 m flock, whatever y.
        check(-2.5, 2.5, Flocking);
        check(-2.01, -2.9, Flocking);
        check(2.3, 0.0, Flocking);
        check(2.9, -1.0, Flocking);
        // Between them: north of y = 0 avoidance, the rest foraging.
        check(0.0, 0.5, Avoidance);
        check(-1.99, 2.9, Avoidance);
        check(1.0, 1e-9, Avoidance);
        check(0.0, -0.5, Foraging);
        check(1.99, -2.9, Foraging);
        // The boundaries belong to the middle (strict comparisons, as Flow-FL's).
        check(-2.0, 1.0, Avoidance);
        check(2.0, -1.0, Foraging);
        check(0.5, 0.0, Foraging);
    }

    #[test]
    fn flockers_steer_out_of_their_band_and_the_goals_fit_the_layout() {
        assert_eq!(flocking_goal(-2.4), (-0.95, -2.5));
        assert_eq!(flocking_goal(2.4), (1.05, 2.5));
        for (gx, gy) in [WEST_GOAL_M, EAST_GOAL_M] {
            assert_ne!(behaviour_at(gx, gy), Behaviour::Flocking);
            assert!(gx.abs().max(gy.abs()) <= PLACE_LAYOUT_HALF_M);
        }
        // West flockers are drawn into the foraging region, east ones into avoidance.
        assert_eq!(
            behaviour_at(WEST_GOAL_M.0, WEST_GOAL_M.1),
            Behaviour::Foraging
        );
        assert_eq!(
            behaviour_at(EAST_GOAL_M.0, EAST_GOAL_M.1),
            Behaviour::Avoidance
        );
    }

    #[test]
    fn assign_follows_the_positions() {
        let pose = |x, y| Pose { x, y, theta: 0.0 };
        let poses = [pose(-2.5, 0.0), pose(0.0, 1.0), pose(0.0, -1.0)];
        let mut of = [Behaviour::Avoidance; 3];
        assign(&mut of, &poses);
        assert_eq!(
            of,
            [
                Behaviour::Flocking,
                Behaviour::Avoidance,
                Behaviour::Foraging
            ]
        );
    }
}

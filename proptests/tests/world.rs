//! Property tests of the world: over random seeds and densities, robots never overlap a wall,
//! an obstacle or each other, and every robot stays inside the arena, at every tick.

use proptest::prelude::*;
use swarmfl_core::config::Preset;
use swarmfl_core::world::{Controllers, World, WorldError};

/// Every violation in the current state, by brute force (independent of the world's grid).
fn violations(w: &World) -> Vec<String> {
    let r = w.robot_radius_m();
    let h = w.arena().half_side_m;
    let mut out = Vec::new();
    for (i, p) in w.poses().iter().enumerate() {
        if p.x.abs() > h - r || p.y.abs() > h - r {
            out.push(format!("robot {i} outside at {p:?}"));
        }
        for (k, o) in w.arena().obstacles.iter().enumerate() {
            if o.distance_sq(p.x, p.y) < r * r {
                out.push(format!("robot {i} overlaps obstacle {k} {o:?} at {p:?}"));
            }
        }
        for (j, q) in w.poses().iter().enumerate().skip(i + 1) {
            let d2 = (p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y);
            if d2 < 4.0 * r * r {
                out.push(format!(
                    "robots {i} and {j} overlap (distance {})",
                    d2.sqrt()
                ));
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    #[test]
    fn no_overlap_ever_and_everyone_stays_inside(
        seed in any::<u64>(),
        robots in 1u32..60,
        side in 0.6f64..6.0,
        obstacles in 0u32..12,
        speed in prop::sample::select(vec![0.025, 0.1, 0.3]),
        spread in prop::sample::select(vec![0.0, 0.5, 1.5]),
    ) {
        let mut c = Preset::Paper.config();
        c.world.robots = robots;
        c.world.arena_side_m = side;
        c.world.cylinders = obstacles / 2;
        c.world.boxes = obstacles - obstacles / 2;
        c.world.cruise_speed_mps = speed;
        c.world.obstacle_spread_half_m = spread;
        c.data.heldout_samples = 0;
        c.contract.penalised_ranks = 0;
        let mut world = match World::new(&c, seed) {
            Ok(w) => w,
            // Too dense to place: a clear error, not a panic.
            Err(WorldError::Placement { why, .. }) => {
                prop_assert!(why.contains("world."), "{why}");
                return Ok(());
            }
            Err(e) => return Err(TestCaseError::fail(format!("unexpected error {e}"))),
        };
        prop_assert_eq!(violations(&world), Vec::<String>::new());
        let mut controllers = Controllers::new(&c, seed);
        for _ in 0..150 {
            let event = controllers.decide(&world);
            world.apply(&event);
            let v = violations(&world);
            prop_assert!(v.is_empty(), "at {}: {:?}", world.time(), v);
        }
        prop_assert_eq!(world.stats().collisions, 0);
    }
}

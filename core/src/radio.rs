//! The radio links the gossip of every aggregation uses (the ledger's blocks and transactions,
//! the stigmergy's entries): the world's peer sets, minus the links a radio cut severs.
//!
//! The radio cut (`ledger.radio_cut_start_s`, `ledger.radio_cut_duration_s`) is a minimal
//! partition for comparing aggregations: while it lasts, no message crosses between the halves
//! x < 0 and x >= 0 of the arena (by the robots' positions at the tick's end). Range-and-bearing
//! sensing, hence data collection, is untouched. It is a property of the radio only, decided by
//! the driver: the reduced state never sees it, so replay does not need it.

use crate::config::Config;
use crate::types::{RobotId, SimTime};
use crate::world::World;

/// Whether the radio cut is in force at `now`.
pub fn cut_active(config: &Config, now: SimTime) -> bool {
    let l = &config.ledger;
    let start_ms = (l.radio_cut_start_s * 1000.0).round() as u64;
    let end_ms = start_ms + (l.radio_cut_duration_s * 1000.0).round() as u64;
    end_ms > start_ms && now.0 >= start_ms && now.0 < end_ms
}

/// Every robot's reachable peers at `now`, in robot order.
pub fn peers(config: &Config, world: &World, now: SimTime) -> Vec<Vec<RobotId>> {
    let robots = config.world.robots;
    let all = (0..robots).map(|r| world.peers(r).to_vec());
    if !cut_active(config, now) {
        return all.collect();
    }
    let poses = world.poses();
    let side = |r: RobotId| poses.get(r as usize).is_some_and(|p| p.x >= 0.0);
    all.enumerate()
        .map(|(a, list)| {
            let a_side = side(a as RobotId);
            list.into_iter().filter(|&b| side(b) == a_side).collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Preset;

    #[test]
    fn the_cut_severs_cross_links_only_inside_its_window() {
        let mut config = Preset::Smoke.config();
        config.ledger.radio_cut_start_s = 10.0;
        config.ledger.radio_cut_duration_s = 5.0;
        assert!(!cut_active(&config, SimTime(9_999)));
        assert!(cut_active(&config, SimTime(10_000)));
        assert!(cut_active(&config, SimTime(14_999)));
        assert!(!cut_active(&config, SimTime(15_000)));
        let world = World::new(&config, 1).unwrap();
        let free = peers(&config, &world, SimTime(0));
        let cut = peers(&config, &world, SimTime(10_000));
        let poses = world.poses();
        let mut severed = 0;
        for (a, (f, c)) in free.iter().zip(&cut).enumerate() {
            for b in f {
                let same = (poses[a].x >= 0.0) == (poses[*b as usize].x >= 0.0);
                assert_eq!(c.contains(b), same, "link {a}-{b}");
                severed += usize::from(!same);
            }
        }
        assert!(
            free.iter().map(Vec::len).sum::<usize>() > 0,
            "robots see each other"
        );
        let _ = severed;
    }
}

//! Tests of the world reducer.

use super::*;
use crate::config::Preset;

fn run(config: &Config, seed: u64, ticks: u64) -> World {
    let mut world = World::new(config, seed).unwrap();
    let mut controllers = Controllers::new(config, seed);
    for _ in 0..ticks {
        let event = controllers.decide(&world);
        world.apply(&event);
    }
    world
}

#[test]
fn smoke_compiles() {
    let w = run(&Preset::Paper.config(), 1, 100);
    assert_eq!(w.stats().collisions, 0);
}

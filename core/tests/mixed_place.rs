//! A mixed swarm by place (`world.mixed.assign = "place"`, Flow-FL's `mixed_by_location`,
//! `world/place.rs`) end to end through the driver: robots change behaviour as they move, the
//! run is the same twice, and its log replays and re-simulates bit for bit.

mod common;

use swarmfl_core::config::{Behaviour, Config, MixedAssign, Preset};
use swarmfl_core::event::Record;
use swarmfl_core::replay;
use swarmfl_core::sim::Sim;

/// `smoke`'s learning in Flow-FL's mixed arena, behaviours by place, 300 s.
fn small() -> Config {
    let mut c = Preset::Smoke.config();
    c.run.duration_s = 300.0;
    c.world.behaviour = Behaviour::Mixed;
    c.world.mixed.assign = MixedAssign::Place;
    c.world.arena_side_m = 5.9;
    c.validate().unwrap();
    c
}

#[test]
fn a_mixed_swarm_by_place_replays_and_resimulates_bit_exactly() {
    let config = small();
    assert!(config.to_toml().contains("assign = \"place\""));
    let seed = 7;
    let mut sim = Sim::new(config.clone(), seed).expect("a run");
    let records: Vec<Record> = sim.by_ref().collect();
    let behaviours = sim
        .state()
        .world
        .behaviours()
        .expect("a mixed swarm has its behaviours");
    assert_eq!(behaviours.assign, MixedAssign::Place);
    let again: Vec<Record> = Sim::new(config.clone(), seed).expect("a run").collect();
    assert!(records == again, "two runs of one seed differ");
    let checkpoints = records
        .iter()
        .filter(|r| matches!(r, Record::Checkpoint(_)))
        .count();
    assert!(checkpoints > 5, "{checkpoints} checkpoints");

    let path = common::write_log("mixed-place", &config, seed, &records);
    let replayed = replay::replay(&path).unwrap();
    let resimulated = replay::resimulate(&path).unwrap();
    assert_eq!(replayed.final_hash, resimulated.final_hash);
    assert_eq!(
        resimulated.config.world.mixed.assign,
        MixedAssign::Place,
        "the recorded configuration names the rule"
    );
    std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
}

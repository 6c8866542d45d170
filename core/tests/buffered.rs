//! The buffered protocol (`contract.protocol = "buffered"`, issue 32) end to end through the
//! driver: a run makes versions, replays and re-simulates bit for bit, runs the same twice,
//! and every Byzantine kind acts under it; faulty robots' submissions are outliers against
//! their bases and cost their stakes.

mod common;

use swarmfl_core::byzantine::byzantine_robots;
use swarmfl_core::config::{ByzantineKind, Config, Preset, RoundProtocol};
use swarmfl_core::contract::ContractState;
use swarmfl_core::event::Record;
use swarmfl_core::metrics::best_node;
use swarmfl_core::replay;
use swarmfl_core::sim::Sim;

/// 7 robots for 300 s, a phase every 30 s, 2 epochs, buffers of K = 3.
fn small() -> Config {
    let mut c = Preset::Smoke.config();
    c.world.robots = 7;
    c.run.duration_s = 300.0;
    c.learn.training_period_s = 30.0;
    c.learn.epochs = 2;
    c.contract.penalised_ranks = 1;
    c.contract.protocol = RoundProtocol::Buffered;
    c.contract.buffer_size = 3;
    c.validate().unwrap();
    c
}

fn run(config: &Config, seed: u64) -> (Vec<Record>, ContractState) {
    let mut sim = Sim::new(config.clone(), seed).expect("a run");
    let records: Vec<Record> = sim.by_ref().collect();
    let ledger = &sim.state().ledger;
    (records, ledger.head_state(best_node(ledger)).clone())
}

#[test]
fn a_buffered_run_makes_versions_and_replays_bit_exactly() {
    let config = small();
    let seed = 5;
    let (records, head) = run(&config, seed);
    assert!(head.round >= 5, "only {} versions", head.round);
    assert!(head.buffered.is_some());
    let (again, _) = run(&config, seed);
    assert!(records == again, "two runs of one seed differ");

    let path = common::write_log("buffered", &config, seed, &records);
    let replayed = replay::replay(&path).unwrap();
    let resimulated = replay::resimulate(&path).unwrap();
    assert_eq!(replayed.final_hash, resimulated.final_hash);
    assert_eq!(
        resimulated.config.contract.protocol,
        RoundProtocol::Buffered,
        "the recorded configuration names the protocol"
    );
    std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
}

#[test]
fn every_byzantine_kind_acts_under_the_buffered_protocol() {
    for kind in ByzantineKind::ALL {
        // A plug-in attack needs a program that offers it (the Python package's tests run it).
        if kind == ByzantineKind::None || kind == ByzantineKind::Plugin {
            continue;
        }
        let mut config = small();
        config.run.duration_s = 150.0;
        config.byzantine.kind = kind;
        config.byzantine.count = 2;
        config.byzantine.wait_for_honest = 1;
        config
            .validate()
            .unwrap_or_else(|e| panic!("{}: {e}", kind.name()));
        let (_, head) = run(&config, 2);
        assert_eq!(
            head.total_units(),
            u128::from(7 * 21 * config.contract.token_units)
        );
        if kind == ByzantineKind::Faulty {
            // Random weights are far from every base: outliers, whose stakes are lost.
            let initial = config.contract.initial_tokens * config.contract.token_units;
            for (robot, &b) in byzantine_robots(&config, 2).iter().enumerate() {
                if b {
                    assert!(
                        head.balances[robot] < initial,
                        "faulty robot {robot} kept its stake"
                    );
                }
            }
        }
    }
}

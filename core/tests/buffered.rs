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

/// The summary's staleness figures (issue 56) agree with the chain: one age per accepted
/// update, every version reaches every node, and the matched ideal reports ages too.
#[test]
fn the_summary_measures_base_ages_and_version_propagation() {
    use swarmfl_core::config::Aggregation;
    use swarmfl_core::summary::RunSummary;
    let summary = |config: &Config| {
        let mut sim = Sim::new(config.clone(), 5).expect("a run");
        let records = sim.by_ref().count() as u64;
        RunSummary::new(sim.config(), 5, sim.state(), records, Default::default())
    };
    let chain = summary(&small());
    let c = &chain.contract;
    let ages = c
        .staleness
        .as_ref()
        .expect("a buffered run has the staleness section");
    let accepted: u64 = ["accepted", "aggregated"]
        .iter()
        .map(|k| c.submissions.get(*k).copied().unwrap_or(0))
        .sum();
    assert_eq!(
        ages.age_versions.iter().sum::<u64>(),
        accepted,
        "{ages:?} {c:?}"
    );
    assert_eq!(ages.age_s.count, accepted);
    assert!(
        ages.age_s.median_s > 0.0,
        "a base is older than its update: {ages:?}"
    );
    assert_eq!(
        ages.stale_refusals,
        c.submissions.get("stale").copied().unwrap_or(0)
    );
    let p = chain
        .ledger
        .details
        .version_propagation
        .as_ref()
        .expect("versions were made");
    assert_eq!(
        p.versions, c.rounds,
        "every version of the final chain reached a head"
    );
    assert_eq!(p.delay.count + p.not_reached, p.versions * 7);
    assert!(
        p.delay.p95_s >= p.delay.median_s && p.delay.max_s > 0.0,
        "{p:?}"
    );
    let median = c.median_heldout_loss_last_1000s.expect("a median");
    assert!(median.is_finite() && median > 0.0);

    let mut ideal = small();
    ideal.learn.aggregation = Aggregation::Matched;
    ideal.validate().unwrap();
    let matched = summary(&ideal);
    let m = &matched.contract;
    let ages = m.staleness.as_ref().expect("the matched ideal has ages");
    assert_eq!(
        m.rounds,
        ages.age_versions.iter().sum::<u64>() / 3,
        "a step per K = 3"
    );
    assert!(m.median_heldout_loss_last_1000s.is_some());
}

//! Issue 37, findings 1 and 2, end to end through the driver with the presets' defaults:
//! inflated sample claims must not pay, a stalled round must not lock its stakes for good, and
//! neither default may move the records of a run in which it never acts.

use swarmfl_core::byzantine::byzantine_robots;
use swarmfl_core::config::{ByzantineKind, Config, Preset};
use swarmfl_core::contract::ContractState;
use swarmfl_core::event::Record;
use swarmfl_core::metrics::best_node;
use swarmfl_core::sim::Sim;

/// Runs `config` to its end with `seed`; returns the records and the best node's contract
/// state.
fn run(config: &Config, seed: u64) -> (Vec<Record>, ContractState) {
    config.validate().expect("a valid configuration");
    let mut sim = Sim::new(config.clone(), seed).expect("a run");
    let records: Vec<Record> = sim.by_ref().collect();
    let ledger = &sim.state().ledger;
    (records, ledger.head_state(best_node(ledger)).clone())
}

/// Finding 1: three smart robots claiming 10^9 samples each in the default `smoke` run (the
/// paper's rule). Before the claim bound they were ranked first, took the bonus of every round
/// and ended far above their 21 tokens; with it, every such submission is refused and they
/// gain nothing.
#[test]
fn inflated_sample_claims_pay_nothing() {
    let mut config = Preset::Smoke.config();
    config.byzantine.kind = ByzantineKind::Smart;
    config.byzantine.count = 3;
    config.byzantine.claimed_samples = 1_000_000_000;
    let seed = 1;
    let (_, head) = run(&config, seed);
    let initial = config.contract.initial_tokens * config.contract.token_units;
    let byzantine = byzantine_robots(&config, seed);
    for (robot, &b) in byzantine.iter().enumerate() {
        if b {
            assert!(
                head.balances[robot] <= initial,
                "smart robot {robot} ends with {} units, above its initial {initial}",
                head.balances[robot]
            );
        }
    }
    assert!(head.round > 0, "the honest robots still aggregate");
}

/// Finding 2: nine faulty robots (outliers) and six honest ones in a swarm of 15 with the
/// paper's quorum of 7: no round can complete. With the presets' deadline the stalled round
/// closes and refunds the honest stakes; before, it stayed locked for good.
#[test]
fn a_stalled_round_is_released_by_the_default_deadline() {
    let mut config = Preset::Smoke.config();
    config.byzantine.kind = ByzantineKind::Faulty;
    config.byzantine.count = 9;
    config.run.duration_s = 2000.0;
    let (_, head) = run(&config, 3);
    assert_eq!(head.round, 0, "no round can reach the quorum");
    assert!(
        head.rounds_timed_out >= 1,
        "the stalled round was never closed (rounds_timed_out = 0)"
    );
    assert!(head.timeout_refunded_units > 0);
}

/// Finding 3: the default deadline and the derived claim bound change no record of a run in
/// which they never act: the same run with the deadline off makes the same records, byte for
/// byte (only the log header's configuration text differs).
#[test]
fn the_defaults_move_no_record_of_an_honest_run() {
    let mut config = Preset::Smoke.config();
    config.run.duration_s = 150.0;
    config.byzantine.kind = ByzantineKind::Smart;
    config.byzantine.count = 2;
    let (with, _) = run(&config, 7);
    config.contract.round_timeout_s = 0.0;
    let (without, _) = run(&config, 7);
    assert!(with.len() > 100);
    assert!(with == without, "the default deadline moved a record");
}

//! Issue 36: `ledger.geth_equivalent` of `summary.json`, end to end. Present under the evm
//! engine with components that add up and a submission the size the encodings give; absent
//! (not even a key) under the native engine, so native summaries do not move.
#![cfg(feature = "evm")]

use swarmfl_core::config::{Config, ContractEngine, Preset};
use swarmfl_core::sim::Sim;
use swarmfl_core::summary::RunSummary;
use swarmfl_core::types::Digest;

fn summary(config: &Config, seed: u64) -> RunSummary {
    config.validate().expect("a valid configuration");
    let mut sim = Sim::new(config.clone(), seed).expect("a run");
    let records = sim.by_ref().count() as u64;
    RunSummary::new(config, seed, sim.state(), records, Digest::default())
}

fn smoke(engine: ContractEngine) -> Config {
    let mut config = Preset::Smoke.config();
    config.run.duration_s = 300.0;
    config.contract.engine = engine;
    config
}

#[test]
fn the_evm_engine_reports_what_geth_would_store_and_native_does_not() {
    let evm = summary(&smoke(ContractEngine::Evm), 7);
    let geth = evm
        .ledger
        .geth_equivalent
        .as_ref()
        .expect("an evm run has the field");
    let c = &geth.components;
    assert_eq!(
        c.total,
        c.transactions + c.headers + c.receipts + c.storage + c.indexes
    );
    assert!(geth.submissions > 0, "the smoke run submits models");
    // A submission: the authors' 91,172 bytes of calldata in a legacy transaction, 91,287 to
    // 91,291 bytes by the sizes of nonce and gas (`contract/evm/geth.rs` tests).
    assert!(
        (91_287..=91_291).contains(&geth.tx_bytes_per_submission),
        "{}",
        geth.tx_bytes_per_submission
    );
    assert!(c.transactions > geth.submissions * 91_287);
    assert!(geth.bytes_per_node_min <= geth.bytes_per_node_mean);
    assert!(geth.bytes_per_node_mean <= geth.bytes_per_node_max);
    assert!(
        geth.state.slots > 712,
        "the shared model alone fills 712 slots"
    );
    assert!(
        geth.storage_archive > geth.state.trie,
        "archive keeps every block's trie"
    );
    // The series: every 500 s until the end (300 s: none), so a longer run has points.
    assert!(geth.series.is_empty());

    let native = summary(&smoke(ContractEngine::Native), 7);
    assert!(native.ledger.geth_equivalent.is_none());
    let json = serde_json::to_value(&native).expect("a summary serialises");
    assert!(
        json["ledger"].get("geth_equivalent").is_none(),
        "the native summary has no geth_equivalent key"
    );
    // The same chain under both engines: the same heights and submissions.
    assert_eq!(evm.ledger.canonical_height, native.ledger.canonical_height);
    assert_eq!(evm.contract.submissions, native.contract.submissions);
}

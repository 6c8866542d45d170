//! Each ledger behaviour against honest nodes: what they refuse, with which reason, and that
//! what they keep stays bounded.

use super::LedgerBehaviour;
use crate::config::{Config, Preset};
use crate::ledger::{LedgerStats, MEMPOOL_MAX, MEMPOOL_PER_SENDER};
use crate::sim::Sim;
use crate::state::State;

/// A small, fast swarm with one or two Byzantine robots behaving as `behaviour` on the ledger.
fn run(behaviour: LedgerBehaviour, count: u32, duration_s: f64) -> (Config, State) {
    let mut c = Preset::Smoke.config();
    c.run.duration_s = duration_s;
    c.world.robots = 8;
    c.learn.lstm_units = 4;
    c.learn.epochs = 1;
    c.learn.training_period_s = 30.0;
    c.byzantine.ledger = behaviour;
    c.byzantine.count = count;
    c.validate().unwrap();
    let mut sim = Sim::new(c.clone(), 7).unwrap();
    for _ in sim.by_ref() {}
    (c, sim.state().clone())
}

fn rejected(stats: &LedgerStats, reason: &str) -> u64 {
    stats.rejections.get(reason).copied().unwrap_or(0)
}

fn honest_chains_check(state: &State, config: &Config) {
    let byzantine = crate::byzantine::byzantine_robots(config, 7);
    for r in 0..config.world.robots {
        if !byzantine[r as usize] {
            state.ledger.check_chain(r).unwrap();
        }
    }
}

#[test]
fn equivocation_is_detected_and_the_swarm_converges() {
    let (config, state) = run(LedgerBehaviour::Equivocate, 2, 300.0);
    let stats = state.ledger.stats();
    let sites: u64 = stats.equivocations.iter().map(|e| e.sites).sum();
    assert!(
        sites > 0,
        "equivocations detected: {:?}",
        stats.equivocations
    );
    let byzantine = crate::byzantine::byzantine_robots(&config, 7);
    for e in &stats.equivocations {
        assert!(
            byzantine[e.sealer as usize],
            "only Byzantine sealers equivocate"
        );
        assert!(e.detected_by > 0);
    }
    honest_chains_check(&state, &config);
    assert!(stats.canonical_height >= 20, "the chain grows: {stats:?}");
}

#[test]
fn a_flood_is_bounded_by_the_mempool_caps() {
    let (config, state) = run(LedgerBehaviour::Flood, 1, 200.0);
    let stats = state.ledger.stats();
    assert!(
        rejected(&stats, "nonce_gap") > 0,
        "far nonces refused: {:?}",
        stats.rejections
    );
    assert!(
        rejected(&stats, "sender_cap") + rejected(&stats, "nonce_taken") + stats.mempool_replaced
            > 0,
        "per-sender bound and replacement rule at work: {:?}",
        stats.rejections
    );
    assert!(stats.mempool_max <= u64::from(MEMPOOL_MAX));
    let byzantine = crate::byzantine::byzantine_robots(&config, 7);
    let flooder = byzantine.iter().position(|b| *b).unwrap() as u32;
    for r in 0..config.world.robots {
        let pending = state
            .ledger
            .mempool(r)
            .iter()
            .filter(|h| state.ledger.tx(h).unwrap().tx.sender == flooder)
            .count() as u32;
        assert!(pending <= MEMPOOL_PER_SENDER, "node {r} keeps {pending}");
    }
    // Evicted and replaced transactions leave the nodes: what a node holds is its mempool
    // and the transactions of blocks, however many the flooder sent.
    let in_blocks: std::collections::BTreeSet<_> = state
        .ledger
        .blocks()
        .flat_map(|(_, entry)| entry.block.txs.iter().copied())
        .collect();
    assert!(
        stats.mempool_replaced + stats.mempool_evicted > 0,
        "the flood replaced or evicted pending transactions: {stats:?}"
    );
    for r in 0..config.world.robots {
        let held = state.ledger.known_tx_count(r);
        let bound = state.ledger.mempool(r).len() + in_blocks.len();
        assert!(
            held <= bound,
            "node {r} holds {held} transactions, bound {bound}"
        );
    }
    honest_chains_check(&state, &config);
}

#[test]
fn replays_are_refused() {
    let (config, state) = run(LedgerBehaviour::Replay, 1, 200.0);
    let stats = state.ledger.stats();
    assert!(
        rejected(&stats, "bad_signature") > 0,
        "a transaction signed for another chain fails: {:?}",
        stats.rejections
    );
    honest_chains_check(&state, &config);
}

#[test]
fn invalid_items_are_refused_before_body_work_and_not_stored() {
    let (config, state) = run(LedgerBehaviour::SpamInvalid, 1, 120.0);
    let stats = state.ledger.stats();
    for reason in ["undecodable", "bad_signature", "oversize"] {
        assert!(
            rejected(&stats, reason) > 0,
            "{reason}: {:?}",
            stats.rejections
        );
    }
    assert!(
        rejected(&stats, "bad_tx") + rejected(&stats, "recent_signer") > 0,
        "{:?}",
        stats.rejections
    );
    // Only valid transactions reach the shared storage: the honest submissions and the
    // (few) valid ones inside valid blocks; the forged bodies never do.
    for (_, entry) in state.ledger.blocks() {
        for tx in &entry.block.txs {
            assert!(state.ledger.tx(tx).unwrap().intrinsic.is_ok());
        }
    }
    assert!(stats.stored_txs < 200, "stored {}", stats.stored_txs);
    honest_chains_check(&state, &config);
}

#[test]
fn future_blocks_are_refused_and_not_stored() {
    let (config, state) = run(LedgerBehaviour::FutureTimestamp, 1, 120.0);
    let stats = state.ledger.stats();
    assert!(
        rejected(&stats, "future_block") > 0,
        "{:?}",
        stats.rejections
    );
    let now = state.ledger.now().0;
    for (_, entry) in state.ledger.blocks() {
        assert!(
            entry.block.header.timestamp_ms <= now,
            "a future block was stored"
        );
    }
    honest_chains_check(&state, &config);
}

#[test]
fn withheld_blocks_cost_reorgs_but_the_swarm_converges() {
    let (config, state) = run(LedgerBehaviour::Withhold, 2, 300.0);
    let stats = state.ledger.stats();
    assert!(stats.reorgs > 0, "withholding forks the swarm: {stats:?}");
    honest_chains_check(&state, &config);
    assert!(stats.canonical_height >= 20);
}

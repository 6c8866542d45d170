#![no_main]
//! Fuzzes the ledger's decoders and verification. The first input byte picks the mode:
//!
//! - raw: the bytes are decoded as a transaction, a wire item and a ledger event (the types the
//!   ledger reads from the wire and the log), then injected as foreign bytes into a node
//!   (`LedgerEvent::Inject`, the path of Byzantine input);
//! - re-signed: the bytes are decoded as a wire item, which is then made to pass the cheap
//!   checks (senders and signers in range, honest signatures, the right transaction root, the
//!   genesis block as parent when asked) so that the fuzzer reaches the Clique rules, nonces
//!   and contract execution;
//! - events: the bytes are decoded as a list of (time step, ledger event) pairs applied in order.
//!
//! Nothing may panic; an injected item is recorded as accepted, rejected or duplicate, never an
//! error; after every input each node's canonical chain must pass `Ledger::check_chain`.

use std::sync::{Arc, OnceLock};

use libfuzzer_sys::fuzz_target;
use swarmfl_core::config::Preset;
use swarmfl_core::contract::ContractParams;
use swarmfl_core::ledger::block::tx_root;
use swarmfl_core::ledger::{Ledger, LedgerEvent, Tx, WireItem};
use swarmfl_core::types::SimTime;

const ROBOTS: u32 = 4;
/// Far enough from genesis that fuzzed timestamps can be valid.
const AT_MS: u64 = 1_000_000;

fn template() -> &'static Ledger {
    static LEDGER: OnceLock<Ledger> = OnceLock::new();
    LEDGER.get_or_init(|| {
        let mut config = Preset::Smoke.config();
        config.world.robots = ROBOTS;
        config.contract.penalised_ranks = 1;
        config.validate().expect("a valid small swarm");
        let params = ContractParams::from_config(&config, Arc::from(vec![0i64; 8]));
        Ledger::new(&config, 7, params)
    })
}

fn check(ledger: &Ledger) {
    for node in 0..ROBOTS {
        if let Err(e) = ledger.check_chain(node) {
            panic!("node {node}'s canonical chain is invalid: {e}");
        }
    }
}

fn inject(ledger: &mut Ledger, node: u32, bytes: Vec<u8>) {
    let event = LedgerEvent::Inject {
        node: node % ROBOTS,
        bytes,
    };
    let applied = ledger
        .apply(SimTime(AT_MS), &event)
        .unwrap_or_else(|e| panic!("an injection is an error instead of a rejection: {e}"));
    assert!(
        applied.accepted + applied.rejected + applied.duplicates >= 1,
        "an injected item is neither accepted, rejected nor a duplicate: {applied:?}"
    );
}

fn resign(ledger: &Ledger, tx: &Tx) -> Tx {
    Tx::signed(
        ledger.keys(),
        tx.sender % ROBOTS,
        tx.nonce,
        tx.value_units,
        tx.call.clone(),
    )
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let mut ledger = template().clone();
    match mode % 3 {
        0 => {
            if let Ok(tx) = Tx::decode(rest) {
                let _ = tx.hash_and_size();
                let _ = tx.signature_ok(ledger.keys());
            }
            let _ = rmp_serde::from_slice::<LedgerEvent>(rest);
            if let Ok(item) = rmp_serde::from_slice::<WireItem>(rest) {
                let _ = item.encode();
            }
            inject(&mut ledger, u32::from(mode / 3), rest.to_vec());
        }
        1 => {
            let Ok(item) = rmp_serde::from_slice::<WireItem>(rest) else {
                return;
            };
            let item = match item {
                WireItem::Tx(tx) => WireItem::Tx(resign(&ledger, &tx)),
                WireItem::Block(mut block) => {
                    block.txs = block.txs.iter().map(|tx| resign(&ledger, tx)).collect();
                    let ids: Vec<_> = block.txs.iter().map(|tx| tx.hash_and_size().0).collect();
                    block.header.tx_root = tx_root(&ids);
                    if mode & 0x80 != 0 {
                        block.header.parent = ledger.genesis();
                        block.header.height = 1;
                    }
                    block.header.signer %= ROBOTS;
                    block.header.signature = ledger
                        .keys()
                        .sign(block.header.signer, &block.header.signing_hash());
                    WireItem::Block(block)
                }
            };
            inject(&mut ledger, u32::from(mode / 3), item.encode());
        }
        _ => {
            let Ok(events) = rmp_serde::from_slice::<Vec<(u16, LedgerEvent)>>(rest) else {
                return;
            };
            let mut at_ms = 0u64;
            for (step_ms, event) in events.iter().take(64) {
                at_ms += u64::from(*step_ms);
                let _ = ledger.apply(SimTime(at_ms), event);
            }
        }
    }
    check(&ledger);
});

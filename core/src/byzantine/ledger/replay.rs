//! `replay`: every five seconds the robot re-sends a transaction from its own chain (refused:
//! the nonce is used, or already known) and one of its own transactions signed for another
//! chain (refused: the signature commits to the genesis id, see `ledger::tx`).

use super::{every, inject_to, Behaviour, View};
use crate::contract::Call;
use crate::ledger::{LedgerEvent, Tx, WireItem};
use crate::rng::Rng;
use crate::types::Digest;

#[derive(Default)]
pub(super) struct Replay {
    last_ms: u64,
}

impl Behaviour for Replay {
    fn on_tick(&mut self, view: &View, rng: &mut Rng) -> Vec<LedgerEvent> {
        if !every(view.now, 5_000, &mut self.last_ms) || view.peers.is_empty() {
            return Vec::new();
        }
        let ledger = view.ledger;
        let mut out = Vec::new();
        let chain = ledger.canonical_chain(view.robot);
        let old: Vec<_> = chain
            .iter()
            .filter_map(|h| ledger.block(h))
            .flat_map(|e| e.block.txs.iter().copied())
            .collect();
        if !old.is_empty() {
            let pick = old[rng.below(old.len() as u64) as usize];
            if let Some(entry) = ledger.tx(&pick) {
                out.extend(inject_to(view.peers, &WireItem::Tx((*entry.tx).clone())));
            }
        }
        let (head, _) = ledger.head(view.robot);
        let nonce = ledger
            .block(&head)
            .map_or(0, |e| e.next_nonce[view.robot as usize]);
        let elsewhere = ledger
            .keys()
            .clone()
            .for_chain(Digest::of(b"another run of swarmfl"));
        let foreign = Tx::signed(
            &elsewhere,
            view.robot,
            nonce,
            0,
            Call::Transfer {
                to: (view.robot + 1) % ledger.robots(),
                amount_units: 1,
            },
        );
        out.extend(inject_to(view.peers, &WireItem::Tx(foreign)));
        out
    }
}

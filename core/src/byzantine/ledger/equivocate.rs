//! `equivocate`: right after sealing a block, the robot signs a second block on the same parent
//! (same height, same time, another body: a self-transfer of nothing) and sends it to every
//! other peer in its range, while honest gossip carries the first. The swarm holds two equally
//! heavy heads until a child settles one. Honest nodes cannot refuse the twin (each block is
//! valid alone) but keep the pair as evidence against its signer as soon as they know both
//! (see `ledger::Node::evidence`).

use super::{inject_to, signed_block, Behaviour, View};
use crate::contract::Call;
use crate::ledger::{BlockHash, LedgerEvent, Tx, WireItem};
use crate::rng::Rng;

#[derive(Default)]
pub(super) struct Equivocate;

impl Behaviour for Equivocate {
    fn after_seal(&mut self, view: &View, block: BlockHash, _rng: &mut Rng) -> Vec<LedgerEvent> {
        let Some(entry) = view.ledger.block(&block) else {
            return Vec::new();
        };
        let header = &entry.block.header;
        let Some(parent) = view.ledger.block(&header.parent) else {
            return Vec::new();
        };
        let nonce = parent.next_nonce[view.robot as usize];
        let call = Call::Transfer {
            to: view.robot,
            amount_units: 0,
        };
        let mut tx = Tx::signed(view.ledger.keys(), view.robot, nonce, 0, call);
        if entry.block.txs.first() == Some(&tx.hash_and_size().0) {
            // The honest block already holds this very transaction: send one unit instead.
            tx = Tx::signed(
                view.ledger.keys(),
                view.robot,
                nonce,
                0,
                Call::Transfer {
                    to: view.robot,
                    amount_units: 1,
                },
            );
        }
        let twin = signed_block(
            view.ledger,
            view.robot,
            header.parent,
            header.timestamp_ms,
            vec![tx],
        );
        // Every other peer gets the twin first.
        let targets: Vec<_> = view
            .peers
            .iter()
            .copied()
            .enumerate()
            .filter(|(i, _)| i % 2 == 1)
            .map(|(_, p)| p)
            .collect();
        inject_to(&targets, &WireItem::Block(twin))
    }
}

//! `future-timestamp`: every block period the robot signs a block on its head stamped an hour
//! ahead and sends it to its peers. Each node compares the stamp with its own clock and refuses
//! it (`future_block`) before looking at the body; nothing is stored.

use super::{every, inject_to, signed_block, Behaviour, View};
use crate::ledger::{LedgerEvent, WireItem};
use crate::rng::Rng;

/// How far ahead the forged stamps are, ms.
const AHEAD_MS: u64 = 3_600_000;

#[derive(Default)]
pub(super) struct FutureTimestamp {
    last_ms: u64,
}

impl Behaviour for FutureTimestamp {
    fn on_tick(&mut self, view: &View, _rng: &mut Rng) -> Vec<LedgerEvent> {
        let period = view.ledger.period_ms().max(1);
        if !every(view.now, period, &mut self.last_ms) || view.peers.is_empty() {
            return Vec::new();
        }
        let (head, _) = view.ledger.head(view.robot);
        let block = signed_block(
            view.ledger,
            view.robot,
            head,
            view.now.0 + AHEAD_MS,
            Vec::new(),
        );
        inject_to(view.peers, &WireItem::Block(block))
    }
}

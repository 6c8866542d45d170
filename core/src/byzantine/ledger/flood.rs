//! `flood`: every second the robot signs four transfers with nonces spread over and beyond the
//! nonce window (some the same nonce with another body) and sends each to every peer in range.
//! Honest nodes keep at most `MAX_NONCE_GAP` nonces ahead, `MEMPOOL_PER_SENDER` per sender (one
//! per nonce: the replacement rule keeps the lowest id) and `MEMPOOL_MAX` in all, evicting the
//! most prolific sender first: the flood costs refusals and bytes, never an honest slot.

use super::{every, inject_to, Behaviour, View};
use crate::contract::Call;
use crate::ledger::{LedgerEvent, Tx, WireItem, MAX_NONCE_GAP};
use crate::rng::Rng;

#[derive(Default)]
pub(super) struct Flood {
    last_ms: u64,
}

impl Behaviour for Flood {
    fn on_tick(&mut self, view: &View, rng: &mut Rng) -> Vec<LedgerEvent> {
        if !every(view.now, 1_000, &mut self.last_ms) || view.peers.is_empty() {
            return Vec::new();
        }
        let (head, _) = view.ledger.head(view.robot);
        let next = view
            .ledger
            .block(&head)
            .map_or(0, |e| e.next_nonce[view.robot as usize]);
        let robots = u64::from(view.ledger.robots());
        let mut out = Vec::new();
        for _ in 0..4 {
            let call = Call::Transfer {
                to: rng.below(robots) as u32,
                amount_units: rng.below(1_000),
            };
            let nonce = next + rng.below(MAX_NONCE_GAP + 8);
            let tx = Tx::signed(view.ledger.keys(), view.robot, nonce, 0, call);
            out.extend(inject_to(view.peers, &WireItem::Tx(tx)));
        }
        out
    }
}

//! `spam-invalid`: every two seconds the robot sends one invalid item to its peers, in turn:
//! garbage bytes (`undecodable`), a transaction signed by it in another robot's name
//! (`bad_signature`), a block claiming another signer with a large body (`bad_signature`,
//! refused on the header: the body is never hashed into storage), a block of its own whose
//! transaction has a wrong nonce (`bad_tx`, cached by id in a bounded cache), and once per run
//! a block larger than the wire limit (`oversize`, refused before decoding).

use std::sync::Arc;

use super::{every, inject_to, signed_block, Behaviour, View};
use crate::contract::Call;
use crate::ledger::{LedgerEvent, Sig, Tx, WireItem, MAX_WIRE_BYTES};
use crate::rng::Rng;

#[derive(Default)]
pub(super) struct SpamInvalid {
    last_ms: u64,
    sent: u64,
}

impl Behaviour for SpamInvalid {
    fn on_tick(&mut self, view: &View, rng: &mut Rng) -> Vec<LedgerEvent> {
        if !every(view.now, 2_000, &mut self.last_ms) || view.peers.is_empty() {
            return Vec::new();
        }
        let ledger = view.ledger;
        let robot = view.robot;
        let robots = ledger.robots();
        let other = (robot + 1 + rng.below(u64::from(robots.max(2) - 1)) as u32) % robots;
        let (head, _) = ledger.head(robot);
        let nonce = ledger
            .block(&head)
            .map_or(0, |e| e.next_nonce[robot as usize]);
        let transfer = |amount_units| Call::Transfer {
            to: robot,
            amount_units,
        };
        let case = if self.sent == 0 { 4 } else { self.sent % 4 };
        self.sent += 1;
        let bytes_or_item: Result<Vec<u8>, WireItem> = match case {
            0 => Ok((0..64).map(|_| rng.below(256) as u8).collect()),
            1 => {
                let mut tx = Tx::signed(ledger.keys(), robot, 0, 0, transfer(1));
                tx.sender = other;
                Err(WireItem::Tx(tx))
            }
            2 => {
                let junk: Vec<Tx> = (0..32)
                    .map(|i| Tx::signed(ledger.keys(), robot, nonce + i, 0, transfer(i)))
                    .collect();
                let mut block = signed_block(ledger, robot, head, view.now.0, junk);
                block.header.signer = other;
                Err(WireItem::Block(block))
            }
            3 => {
                let bad = Tx::signed(ledger.keys(), robot, nonce + 5, 0, transfer(2));
                Err(WireItem::Block(signed_block(
                    ledger,
                    robot,
                    head,
                    view.now.0,
                    vec![bad],
                )))
            }
            _ => {
                // Models of 4096 weights (about 30 KB each) until past the wire limit.
                let per_tx = 4096usize;
                // Weights below 2^32 encode in 5 bytes: about 20 KB a transaction.
                let count = MAX_WIRE_BYTES / (per_tx * 5) + 4;
                let txs: Vec<Tx> = (0..count as u64)
                    .map(|i| {
                        let weights: Arc<[i64]> = (0..per_tx as i64)
                            .map(|w| (w + 1) * 1_000_003)
                            .collect::<Vec<_>>()
                            .into();
                        let mut tx = Tx::signed(
                            ledger.keys(),
                            robot,
                            nonce + i,
                            0,
                            Call::SubmitModel {
                                weights,
                                samples: 1,
                            },
                        );
                        tx.signature = Sig::ZERO;
                        tx
                    })
                    .collect();
                Err(WireItem::Block(signed_block(
                    ledger, robot, head, view.now.0, txs,
                )))
            }
        };
        match bytes_or_item {
            Ok(bytes) => view
                .peers
                .iter()
                .map(|&node| LedgerEvent::Inject {
                    node,
                    bytes: bytes.clone(),
                })
                .collect(),
            Err(item) => inject_to(view.peers, &item),
        }
    }
}

//! The reducer: [`Ledger::apply`] folds one event, and what it does with a valid block (store
//! it once, seal it, add it to a node's tree and run fork choice).

use std::collections::BTreeMap;

use super::intake::Carry;
use super::{
    block, Applied, BlockEntry, BlockHash, BlockHeader, Flight, ItemRef, Ledger, LedgerError,
    LedgerEvent, RejectReason, Sig, TxHash, MAX_EVIDENCE,
};
use crate::types::{RobotId, SimTime};

impl Ledger {
    /// Folds one event at time `at`. A refused item is recorded at its node and is not an
    /// error; an event that cannot happen (unknown node, delivery of a message not in flight,
    /// a sealing against the rules) is an error and leaves the state unchanged.
    pub fn apply(&mut self, at: SimTime, event: &LedgerEvent) -> Result<Applied, LedgerError> {
        if at < self.now {
            return Err(LedgerError::TimeWentBack { at, now: self.now });
        }
        self.check_event(event)?;
        // A sealing is built and validated before anything changes.
        let sealed = match event {
            LedgerEvent::Seal {
                node,
                txs,
                evidence,
                ..
            } => Some(
                self.build_seal(*node, txs, evidence, at)
                    .map_err(|reason| LedgerError::InvalidSeal {
                        node: *node,
                        reason,
                    })?,
            ),
            _ => None,
        };
        self.metrics.sample_until(at, &self.nodes, &self.blocks);
        self.now = at;
        let mut applied = Applied::default();
        match event {
            LedgerEvent::Submit { tx } => {
                let hash = self.store_tx(tx);
                self.metrics
                    .on_submit(hash, tx, self.txs[&hash].size_bytes, at);
                self.receive_tx(tx.sender, hash, at, &mut applied);
            }
            LedgerEvent::Seal { node, .. } => {
                let (hash, entry) = sealed.expect("built above");
                self.insert_valid(hash, entry);
                self.accept_block(*node, hash, at, &mut applied);
            }
            LedgerEvent::Send {
                from,
                to,
                items,
                lost,
            } => {
                let seq = self.messages_sent;
                self.messages_sent += 1;
                let bytes: u64 = items.iter().map(|i| self.item_bytes(i)).sum();
                self.metrics.on_send(bytes, *lost);
                if !lost {
                    for item in items {
                        if let ItemRef::Tx(h) = item {
                            self.carry_tx(h, Carry::Add);
                        }
                    }
                    self.flights.insert(
                        seq,
                        Flight {
                            from: *from,
                            to: *to,
                            items: items.clone(),
                        },
                    );
                }
            }
            LedgerEvent::Deliver { message } => {
                let flight = self
                    .flights
                    .remove(message)
                    .expect("checked in check_event");
                for item in &flight.items {
                    match item {
                        ItemRef::Block(h) => self.receive_block(flight.to, *h, at, &mut applied),
                        ItemRef::Tx(h) => self.receive_tx(flight.to, *h, at, &mut applied),
                    }
                }
                self.uncarry(&flight);
                self.nodes[flight.to as usize].version += 1;
            }
            LedgerEvent::Inject { node, bytes } => self.inject(*node, bytes, at, &mut applied),
            LedgerEvent::Restart { node } => {
                let n = &mut self.nodes[*node as usize];
                n.mempool.clear();
                n.head_since = at;
                n.version += 1;
                self.head_journal.push(*node);
                let lost: Vec<u64> = self
                    .flights
                    .iter()
                    .filter(|(_, f)| f.to == *node)
                    .map(|(seq, _)| *seq)
                    .collect();
                for seq in lost {
                    let flight = self.flights.remove(&seq).expect("listed above");
                    self.uncarry(&flight);
                }
                applied.head_changes += 1;
            }
        }
        Ok(applied)
    }

    /// The block `node` seals on its head at `at` with `txs` and the proofs of the twin pairs
    /// `evidence`, validated.
    fn build_seal(
        &self,
        node: RobotId,
        txs: &[TxHash],
        evidence: &[(BlockHash, BlockHash)],
        at: SimTime,
    ) -> Result<(BlockHash, BlockEntry), RejectReason> {
        let n = self.node(node);
        let height = n.canonical.len() as u64;
        let evidence = self.evidence_of(evidence).ok_or_else(|| {
            RejectReason::BadEvidence("a named pair is not an equivocation".into())
        })?;
        let mut header = BlockHeader {
            parent: n.head,
            height,
            timestamp_ms: self.clock_ms(node, at),
            signer: node,
            difficulty: self.expected_difficulty(&n.head, node),
            tx_root: block::tx_root(txs),
            signature: Sig::ZERO,
            evidence,
        };
        header.signature = self.keys.sign(node, &header.signing_hash());
        let entry = self.validate(&header, txs, &BTreeMap::new())?;
        Ok((header.hash_and_size().0, entry))
    }

    /// A message left the air (delivered, or lost with its receiver's restart): its
    /// transactions are carried by one message fewer.
    fn uncarry(&mut self, flight: &Flight) {
        for item in &flight.items {
            if let ItemRef::Tx(h) = item {
                self.carry_tx(h, Carry::Remove);
            }
        }
    }

    /// Stores a valid block once; its transactions are carried by it from then on (blocks are
    /// never removed).
    pub(super) fn insert_valid(&mut self, hash: BlockHash, entry: BlockEntry) {
        if self.blocks.contains_key(&hash) {
            return;
        }
        for tx in &entry.block.txs {
            self.carry_tx(tx, Carry::Add);
        }
        let parent = entry.block.header.parent;
        self.sealed_on
            .entry((parent, entry.block.header.signer))
            .or_default()
            .push(hash);
        self.blocks.insert(hash, entry);
        self.blocks
            .get_mut(&parent)
            .expect("a valid block's parent is stored")
            .children += 1;
    }

    /// Adds a valid block whose parent the node knows to the node's tree; fork choice.
    pub(super) fn accept_block(
        &mut self,
        node: RobotId,
        hash: BlockHash,
        at: SimTime,
        applied: &mut Applied,
    ) {
        let entry = &self.blocks[&hash];
        let header = entry.block.header.clone();
        let td = entry.total_difficulty;
        let size_bytes = entry.size_bytes;
        let tx_ids = entry.block.txs.clone();
        let n = &mut self.nodes[node as usize];
        assert!(
            n.known_blocks.contains(&header.parent),
            "accepting a block whose parent is unknown"
        );
        n.known_blocks.insert(hash);
        n.stored_bytes += size_bytes;
        n.version += 1;
        applied.accepted += 1;
        for tx in &tx_ids {
            if self.hold_tx(node, tx) {
                self.metrics.on_seen(tx, node, at);
            }
        }
        // Equivocation: another block the same signer sealed on the same parent, known here.
        // An honest sealer never seals twice on one parent (its head moves to its own child,
        // which is heavier than the parent), so this is evidence, not a coincidence.
        let twin = self
            .sealed_on
            .get(&(header.parent, header.signer))
            .and_then(|v| {
                v.iter()
                    .find(|h| **h != hash && self.nodes[node as usize].known_blocks.contains(*h))
                    .copied()
            });
        let n = &mut self.nodes[node as usize];
        if let Some(twin) = twin {
            if n.evidence.len() < MAX_EVIDENCE {
                n.evidence
                    .entry((header.signer, header.parent))
                    .or_insert((twin.min(hash), twin.max(hash)));
            }
        }
        if header.parent != n.head {
            n.side_blocks += 1;
        }
        n.by_td.entry(td).or_default().push(hash);
        // Fork choice: the greatest total difficulty; a tie keeps the current head...
        if td > self.blocks[&n.head].total_difficulty {
            self.set_head(node, hash, at);
            applied.head_changes += 1;
        }
        // ...unless the node may not seal on it (see `unstick`).
        if self.unstick(node, at) {
            applied.head_changes += 1;
        }
    }
}

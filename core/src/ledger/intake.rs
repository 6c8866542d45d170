//! How items reach a node: a submitted or gossiped transaction into the mempool (with its
//! bounds), a gossiped block into the node's tree, foreign bytes decoded and checked before
//! anything is stored, and the record of what the node refused.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::{
    block, tx, Applied, BlockEntry, BlockHash, ItemRef, Ledger, RejectReason, Rejection, Tx,
    TxEntry, TxHash, WireBlock, WireItem, MAX_INVALID_CACHE, MAX_NONCE_GAP, MAX_REFUSED_KEPT,
    MAX_REJECTIONS_KEPT, MAX_WIRE_BYTES, MEMPOOL_MAX, MEMPOOL_PER_SENDER,
};
use crate::types::{Digest, RobotId, SimTime};

/// A change of the number of things (stored blocks, messages in flight) that carry a
/// transaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Carry {
    /// One more carries it.
    Add,
    /// One fewer carries it.
    Remove,
}

/// Why a pending transaction leaves a mempool to make room.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Leaves {
    /// Another transaction with the same sender and nonce and a lower id replaces it.
    Replaced,
    /// A full mempool evicts it (see [`MEMPOOL_MAX`]).
    Evicted,
}

impl Ledger {
    /// A transaction's storage entry with its intrinsic checks (sender, size, signature).
    fn tx_entry(&self, tx: &Tx, size: usize) -> TxEntry {
        let intrinsic = if tx.sender >= self.robots {
            Err(RejectReason::UnknownSender(tx.sender))
        } else if size > tx::MAX_TX_BYTES {
            Err(RejectReason::Malformed(format!(
                "{size} bytes, more than the {} allowed",
                tx::MAX_TX_BYTES
            )))
        } else if !tx.signature_ok(&self.keys) {
            Err(RejectReason::BadSignature)
        } else {
            Ok(())
        };
        TxEntry {
            tx: Arc::new(tx.clone()),
            size_bytes: size as u32,
            intrinsic,
            held_by: vec![0u64; self.robots.div_ceil(64) as usize].into(),
            carried_by: 0,
        }
    }

    /// Stores a transaction (once) with its intrinsic checks; returns its id.
    pub(super) fn store_tx(&mut self, tx: &Tx) -> TxHash {
        let bytes = tx.encode();
        let hash = Digest::of(&bytes);
        if !self.txs.contains_key(&hash) {
            let entry = self.tx_entry(tx, bytes.len());
            self.txs.insert(hash, entry);
        }
        hash
    }

    fn reject(
        &mut self,
        node: RobotId,
        item: Option<ItemRef>,
        reason: RejectReason,
        at: SimTime,
        applied: &mut Applied,
    ) {
        self.metrics.on_reject(&reason);
        if let Some(ItemRef::Tx(hash)) = item {
            if !self.holds_tx(node, &hash) {
                self.remember_refused(node, hash);
            }
            self.drop_if_unused(&hash);
        }
        let n = &mut self.nodes[node as usize];
        n.rejections.push_back(Rejection { at, item, reason });
        if n.rejections.len() > MAX_REJECTIONS_KEPT {
            n.rejections.pop_front();
        }
        n.rejected_total += 1;
        n.version += 1;
        applied.rejected += 1;
    }

    /// A node learns of a stored transaction: intrinsic checks, nonce against its chain, then
    /// the mempool's bounds (replacement rule, per-sender cap, global cap with eviction). Only
    /// an admitted transaction becomes known; a refused one is remembered (bounded) as refused.
    pub(super) fn receive_tx(
        &mut self,
        node: RobotId,
        hash: TxHash,
        at: SimTime,
        applied: &mut Applied,
    ) {
        if self.knows_tx(node, &hash) {
            applied.duplicates += 1;
            return;
        }
        let n = &self.nodes[node as usize];
        let entry = &self.txs[&hash];
        let item = Some(ItemRef::Tx(hash));
        if let Err(reason) = &entry.intrinsic {
            let reason = reason.clone();
            return self.reject(node, item, reason, at, applied);
        }
        let (sender, nonce) = (entry.tx.sender, entry.tx.nonce);
        let expected = self.blocks[&n.head].next_nonce[sender as usize];
        if nonce < expected {
            let reason = RejectReason::ReplayedNonce { nonce, expected };
            return self.reject(node, item, reason, at, applied);
        }
        if nonce > expected + MAX_NONCE_GAP {
            let reason = RejectReason::NonceGap { nonce, expected };
            return self.reject(node, item, reason, at, applied);
        }
        // A pending transaction with the same nonce (the lowest id if several) gives way to a
        // lower id; otherwise the caps decide.
        let same = n.mempool.lowest_with_nonce(sender, nonce);
        let leaving = match same {
            Some(same) if same < hash => {
                return self.reject(node, item, RejectReason::NonceTaken { nonce }, at, applied);
            }
            Some(same) => Some((same, Leaves::Replaced)),
            None => match self.make_room(node, sender) {
                Ok(victim) => victim.map(|v| (v, Leaves::Evicted)),
                Err(reason) => return self.reject(node, item, reason, at, applied),
            },
        };
        if let Some((old, how)) = leaving {
            self.leave_mempool(node, old, how);
        }
        self.hold_tx(node, &hash);
        let n = &mut self.nodes[node as usize];
        n.version += 1;
        n.mempool.insert(hash, sender, nonce, n.arrivals, at);
        n.arrivals += 1;
        applied.accepted += 1;
        self.metrics.on_seen(&hash, node, at);
    }

    /// The mempool's caps for one more pending transaction from `sender` at `node`: Ok(None)
    /// when it fits, Ok(Some(victim)) when it fits once `victim` leaves (a full mempool), or
    /// why it does not fit. New and returning (reorg) transactions go through the same caps.
    pub(super) fn make_room(
        &self,
        node: RobotId,
        sender: RobotId,
    ) -> Result<Option<TxHash>, RejectReason> {
        let mempool = &self.nodes[node as usize].mempool;
        let mine = mempool.count_of(sender);
        if mine >= MEMPOOL_PER_SENDER {
            return Err(RejectReason::SenderCap {
                sender,
                pending: mine,
            });
        }
        if (mempool.len() as u32) < MEMPOOL_MAX {
            return Ok(None);
        }
        // The sender with the most pending (the highest id on ties) gives up its highest
        // nonce, if it has more pending than this sender would have.
        let (victim, count) = mempool.busiest().expect("a full mempool has senders");
        if count <= mine + 1 {
            return Err(RejectReason::MempoolFull {
                pending: mempool.len() as u32,
            });
        }
        let highest = mempool
            .of_sender(victim)
            .next_back()
            .expect("the busiest sender has pending transactions")
            .1;
        Ok(Some(highest))
    }

    /// A replaced or evicted transaction leaves the node (as in geth's pool): it is no longer
    /// known, so a flood of admitted-then-evicted transactions cannot grow the node's memory.
    /// It joins the bounded refused set, so that peers do not send it again at once; it
    /// becomes known again if a block carries it. Unused, it leaves the shared storage.
    pub(super) fn leave_mempool(&mut self, node: RobotId, old: TxHash, how: Leaves) {
        self.nodes[node as usize].mempool.remove(&old);
        self.release_tx(node, &old);
        self.remember_refused(node, old);
        self.drop_if_unused(&old);
        let n = &mut self.nodes[node as usize];
        match how {
            Leaves::Replaced => n.mempool_replaced += 1,
            Leaves::Evicted => n.mempool_evicted += 1,
        }
    }

    /// Marks that `node` holds the stored transaction `hash`; returns whether it is new to it.
    pub(super) fn hold_tx(&mut self, node: RobotId, hash: &TxHash) -> bool {
        let entry = self
            .txs
            .get_mut(hash)
            .expect("a held transaction is stored");
        let fresh = entry.set_held_by(node, true);
        if fresh {
            self.nodes[node as usize].held_txs += 1;
        }
        fresh
    }

    /// Marks that `node` no longer holds the stored transaction `hash`.
    fn release_tx(&mut self, node: RobotId, hash: &TxHash) {
        let entry = self
            .txs
            .get_mut(hash)
            .expect("a held transaction is stored");
        if entry.set_held_by(node, false) {
            self.nodes[node as usize].held_txs -= 1;
        }
    }

    /// Removes a stored transaction that no node holds and nothing carries (no stored block,
    /// no message in flight): a refused, replaced or evicted transaction, so that a sender
    /// cannot grow the shared storage with variants every node refuses. Nothing else reads a
    /// transaction in that state: a node only sends or seals what it holds, and a node that
    /// refused it remembers that by id in its own bounded refused set. If it comes again, it is
    /// stored again with the same checks, so outcomes are as if it had been kept.
    pub(super) fn drop_if_unused(&mut self, hash: &TxHash) {
        if self.txs.get(hash).is_some_and(TxEntry::unused) {
            self.txs.remove(hash);
        }
    }

    /// Counts one more (`Carry::Add`) or one fewer (`Carry::Remove`) stored block or message
    /// in flight carrying the stored transaction `hash`.
    pub(super) fn carry_tx(&mut self, hash: &TxHash, change: Carry) {
        let entry = self
            .txs
            .get_mut(hash)
            .expect("a carried transaction is stored");
        match change {
            Carry::Add => entry.carried_by += 1,
            Carry::Remove => {
                assert!(
                    entry.carried_by > 0,
                    "a transaction uncarried more than carried"
                );
                entry.carried_by -= 1;
            }
        }
        if change == Carry::Remove {
            self.drop_if_unused(hash);
        }
    }

    /// Remembers a refused, replaced or evicted transaction in the node's bounded refused set
    /// (first in, first out), so that it is not examined again while it is there. What the
    /// bound pushes out and the node does not hold is logged as forgotten.
    fn remember_refused(&mut self, node: RobotId, hash: TxHash) {
        let n = &mut self.nodes[node as usize];
        if n.refused_txs.insert(hash) {
            n.refused_order.push_back(hash);
            if n.refused_order.len() > MAX_REFUSED_KEPT {
                let old = n.refused_order.pop_front().expect("not empty");
                n.refused_txs.remove(&old);
                let held = self.txs.get(&old).is_some_and(|e| e.held_by(node));
                if !held {
                    self.nodes[node as usize].forgotten.push(old);
                }
            }
        }
    }

    /// A node receives a stored valid block by id (gossip).
    pub(super) fn receive_block(
        &mut self,
        node: RobotId,
        hash: BlockHash,
        at: SimTime,
        applied: &mut Applied,
    ) {
        let n = &self.nodes[node as usize];
        if n.known_blocks.contains(&hash) {
            applied.duplicates += 1;
            return;
        }
        let header = &self.blocks[&hash].block.header;
        if !n.known_blocks.contains(&header.parent) {
            let reason = RejectReason::UnknownParent(header.parent);
            return self.reject(node, Some(ItemRef::Block(hash)), reason, at, applied);
        }
        let now_ms = self.clock_ms(node, at);
        if header.timestamp_ms > now_ms {
            let reason = RejectReason::FutureBlock {
                got_ms: header.timestamp_ms,
                now_ms,
            };
            return self.reject(node, Some(ItemRef::Block(hash)), reason, at, applied);
        }
        self.accept_block(node, hash, at, applied);
    }

    /// Foreign bytes arrive at a node. Cheapest checks first, and nothing is stored before
    /// it is known valid: the length, the decoding, then for a block its id (known, or cached
    /// as invalid), its parent, its timestamp against the node's clock, its header rules and
    /// signature, and only then its body (hashes, root, limits, execution); for a transaction,
    /// its intrinsic checks. Only a valid block's transactions, and a transaction that passes
    /// its intrinsic checks, enter the shared storage.
    pub(super) fn inject(
        &mut self,
        node: RobotId,
        bytes: &[u8],
        at: SimTime,
        applied: &mut Applied,
    ) {
        if bytes.len() > MAX_WIRE_BYTES {
            let reason = RejectReason::Oversize {
                bytes: bytes.len() as u64,
                limit: MAX_WIRE_BYTES as u64,
            };
            return self.reject(node, None, reason, at, applied);
        }
        let item: WireItem = match rmp_serde::from_slice(bytes) {
            Ok(item) => item,
            Err(e) => {
                return self.reject(
                    node,
                    None,
                    RejectReason::Undecodable(e.to_string()),
                    at,
                    applied,
                )
            }
        };
        match item {
            WireItem::Tx(tx) => self.inject_tx(node, &tx, at, applied),
            WireItem::Block(wire) => self.inject_block(node, &wire, at, applied),
        }
    }

    /// A foreign transaction: a stored one is received as from gossip; a new one is stored
    /// only if it passes its intrinsic checks.
    fn inject_tx(&mut self, node: RobotId, tx: &Tx, at: SimTime, applied: &mut Applied) {
        let encoded = tx.encode();
        let hash = Digest::of(&encoded);
        if self.txs.contains_key(&hash) {
            return self.receive_tx(node, hash, at, applied);
        }
        // Not stored, so not held: only a refusal can make it known.
        if self.nodes[node as usize].refused_txs.contains(&hash) {
            applied.duplicates += 1;
            return;
        }
        let entry = self.tx_entry(tx, encoded.len());
        if let Err(reason) = entry.intrinsic {
            return self.reject(node, Some(ItemRef::Tx(hash)), reason, at, applied);
        }
        self.txs.insert(hash, entry);
        self.receive_tx(node, hash, at, applied);
    }

    /// A foreign block: known or cached as invalid first, then (if not stored) the checks
    /// against the node (parent known, timestamp against its clock) and the block's own
    /// (`check_wire_block`); a valid block is stored with its new transactions and received
    /// as from gossip.
    fn inject_block(
        &mut self,
        node: RobotId,
        wire: &WireBlock,
        at: SimTime,
        applied: &mut Applied,
    ) {
        let (hash, _) = wire.header.hash_and_size();
        let item = Some(ItemRef::Block(hash));
        if self.nodes[node as usize].known_blocks.contains(&hash) {
            applied.duplicates += 1;
            return;
        }
        if let Some(reason) = self.invalid_blocks.get(&hash) {
            let reason = reason.clone();
            return self.reject(node, item, reason, at, applied);
        }
        if !self.blocks.contains_key(&hash) {
            if !self.nodes[node as usize]
                .known_blocks
                .contains(&wire.header.parent)
            {
                let reason = RejectReason::UnknownParent(wire.header.parent);
                return self.reject(node, item, reason, at, applied);
            }
            let now_ms = self.clock_ms(node, at);
            if wire.header.timestamp_ms > now_ms {
                let reason = RejectReason::FutureBlock {
                    got_ms: wire.header.timestamp_ms,
                    now_ms,
                };
                return self.reject(node, item, reason, at, applied);
            }
            match self.check_wire_block(wire) {
                Ok((entry, fresh)) => {
                    self.txs.extend(fresh);
                    self.insert_valid(hash, entry);
                }
                Err(reason) => {
                    // A body that does not match the header's root says nothing about the
                    // header (whose id is the block's): never cached, so that a forged body
                    // cannot poison the honest block's id.
                    if reason.is_intrinsic() {
                        self.cache_invalid(hash, reason.clone());
                    }
                    return self.reject(node, item, reason, at, applied);
                }
            }
        }
        self.receive_block(node, hash, at, applied);
    }

    /// A foreign block not stored yet, checked without storing anything: its transaction
    /// count, its header rules and signature, then its body and execution. Returns its entry
    /// and the entries of its transactions not stored yet.
    fn check_wire_block(
        &self,
        wire: &WireBlock,
    ) -> Result<(BlockEntry, BTreeMap<TxHash, TxEntry>), RejectReason> {
        if wire.txs.len() > block::MAX_BLOCK_TXS {
            return Err(RejectReason::Malformed(format!(
                "{} transactions, more than the {} allowed",
                wire.txs.len(),
                block::MAX_BLOCK_TXS
            )));
        }
        self.validate_header(&wire.header)?;
        let mut fresh = BTreeMap::new();
        let mut ids = Vec::with_capacity(wire.txs.len());
        for tx in &wire.txs {
            let encoded = tx.encode();
            let id = Digest::of(&encoded);
            if !self.txs.contains_key(&id) {
                fresh.insert(id, self.tx_entry(tx, encoded.len()));
            }
            ids.push(id);
        }
        let entry = self.validate(&wire.header, &ids, &fresh)?;
        Ok((entry, fresh))
    }

    /// Caches why a block id is invalid (first in, first out, at most [`MAX_INVALID_CACHE`]).
    fn cache_invalid(&mut self, hash: BlockHash, reason: RejectReason) {
        self.invalid_blocks.insert(hash, reason);
        self.invalid_order.push_back(hash);
        if self.invalid_order.len() > MAX_INVALID_CACHE {
            let old = self.invalid_order.pop_front().expect("not empty");
            self.invalid_blocks.remove(&old);
        }
    }
}

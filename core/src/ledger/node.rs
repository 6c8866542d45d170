//! One robot's node: its view of the block tree, its canonical chain, its mempool, what it
//! knows and what it rejected. Nodes hold only ids; the bodies live once in the ledger's shared
//! storage.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use serde::{Deserialize, Serialize};

use super::block::BlockHash;
use super::tx::TxHash;
use super::ItemRef;
use crate::types::{Digest, RobotId, SimTime};

/// Why a node refused an item. Reasons that depend only on the item (signature, header rules,
/// transaction root, execution) are the same at every node; the others (unknown parent, nonce
/// already used on this node's chain, block from the future) depend on the node's view.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
pub enum RejectReason {
    /// The bytes do not decode to a transaction or a block.
    #[error("undecodable: {0}")]
    Undecodable(String),
    /// Structurally wrong (sizes, counts, ids out of range).
    #[error("malformed: {0}")]
    Malformed(String),
    /// The signature is not the claimed sender's or signer's.
    #[error("bad signature")]
    BadSignature,
    /// The transaction's sender is not an account of this swarm.
    #[error("unknown sender {0}")]
    UnknownSender(RobotId),
    /// The nonce was already used on this node's chain (a replay).
    #[error("replayed nonce {nonce}: next expected {expected}")]
    ReplayedNonce {
        /// The transaction's nonce.
        nonce: u64,
        /// The next nonce of the sender on the chain.
        expected: u64,
    },
    /// The nonce is too far ahead of the next expected one to be kept pending.
    #[error("nonce {nonce} too far ahead of the next expected {expected}")]
    NonceGap {
        /// The transaction's nonce.
        nonce: u64,
        /// The next nonce of the sender on the chain.
        expected: u64,
    },
    /// The block's parent is not in this node's tree (delivered out of order).
    #[error("unknown parent {0:?}")]
    UnknownParent(BlockHash),
    /// The block's signer is not an authorised signer.
    #[error("unauthorised signer {0}")]
    UnauthorisedSigner(RobotId),
    /// Height is not the parent's plus one.
    #[error("height {got}, expected {expected}")]
    BadHeight {
        /// The block's height.
        got: u64,
        /// The parent's height plus one.
        expected: u64,
    },
    /// Sealed before the parent's timestamp plus the block period.
    #[error("timestamp {got_ms} ms before the earliest allowed {earliest_ms} ms")]
    TooEarly {
        /// The block's timestamp.
        got_ms: u64,
        /// Parent timestamp plus the period.
        earliest_ms: u64,
    },
    /// The timestamp lies after the time of delivery.
    #[error("timestamp {got_ms} ms is in the future (now {now_ms} ms)")]
    FutureBlock {
        /// The block's timestamp.
        got_ms: u64,
        /// Time of delivery.
        now_ms: u64,
    },
    /// Difficulty does not match the in-turn rule.
    #[error("difficulty {got}, expected {expected}")]
    BadDifficulty {
        /// The block's difficulty.
        got: u64,
        /// 2 in turn, 1 out of turn.
        expected: u64,
    },
    /// The signer sealed one of the last floor(S/2) blocks of the chain (S signers).
    #[error("signer {0} signed recently")]
    RecentSigner(RobotId),
    /// The signer was removed from the signer set on the block's chain (evidence of an
    /// equivocation carried by an ancestor).
    #[error("signer {0} was removed from the signer set for equivocating")]
    RemovedSigner(RobotId),
    /// The block carries equivocation evidence that does not hold on its chain.
    #[error("bad equivocation evidence: {0}")]
    BadEvidence(String),
    /// The transaction root does not match the transactions.
    #[error("transaction root mismatch")]
    BadTxRoot,
    /// A transaction of the block is invalid on the block's chain.
    #[error("transaction {index}: {reason}")]
    BadTx {
        /// Position in the block.
        index: u32,
        /// Why.
        reason: Box<RejectReason>,
    },
    /// The mempool already holds a transaction of this sender with this nonce and a lower id
    /// (the replacement rule keeps the lowest id, the one every sealer would pick).
    #[error("nonce {nonce} already pending with a lower id")]
    NonceTaken {
        /// The nonce.
        nonce: u64,
    },
    /// The sender already has the most pending transactions a node keeps per sender.
    #[error("sender {sender} has {pending} pending transactions, the most kept per sender")]
    SenderCap {
        /// The sender.
        sender: RobotId,
        /// Its pending transactions.
        pending: u32,
    },
    /// The mempool is full and the sender has at least as many pending as any other.
    #[error("mempool full ({pending} pending)")]
    MempoolFull {
        /// Pending transactions at the node.
        pending: u32,
    },
    /// The block's encoding exceeds the block byte limit.
    #[error("block of {bytes} bytes exceeds the limit of {limit}")]
    Oversize {
        /// Encoded size.
        bytes: u64,
        /// The limit.
        limit: u64,
    },
}

impl RejectReason {
    /// A short stable name of the reason, for counting.
    pub fn kind(&self) -> &'static str {
        match self {
            RejectReason::Undecodable(_) => "undecodable",
            RejectReason::Malformed(_) => "malformed",
            RejectReason::BadSignature => "bad_signature",
            RejectReason::UnknownSender(_) => "unknown_sender",
            RejectReason::ReplayedNonce { .. } => "replayed_nonce",
            RejectReason::NonceGap { .. } => "nonce_gap",
            RejectReason::UnknownParent(_) => "unknown_parent",
            RejectReason::UnauthorisedSigner(_) => "unauthorised_signer",
            RejectReason::BadHeight { .. } => "bad_height",
            RejectReason::TooEarly { .. } => "too_early",
            RejectReason::FutureBlock { .. } => "future_block",
            RejectReason::BadDifficulty { .. } => "bad_difficulty",
            RejectReason::RecentSigner(_) => "recent_signer",
            RejectReason::RemovedSigner(_) => "removed_signer",
            RejectReason::BadEvidence(_) => "bad_evidence",
            RejectReason::BadTxRoot => "bad_tx_root",
            RejectReason::BadTx { .. } => "bad_tx",
            RejectReason::NonceTaken { .. } => "nonce_taken",
            RejectReason::SenderCap { .. } => "sender_cap",
            RejectReason::MempoolFull { .. } => "mempool_full",
            RejectReason::Oversize { .. } => "oversize",
        }
    }

    /// True when the reason depends only on the item's id (for a block, its header, which
    /// commits to the parent and to the body through the root), so it holds at every node and
    /// may be cached by id. A body that does not match the root is not: another body may.
    pub fn is_intrinsic(&self) -> bool {
        !matches!(
            self,
            RejectReason::UnknownParent(_)
                | RejectReason::FutureBlock { .. }
                | RejectReason::BadTxRoot
                | RejectReason::ReplayedNonce { .. }
                | RejectReason::NonceGap { .. }
                | RejectReason::NonceTaken { .. }
                | RejectReason::SenderCap { .. }
                | RejectReason::MempoolFull { .. }
        )
    }
}

/// A refusal recorded by a node.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rejection {
    /// When.
    pub at: SimTime,
    /// The item (None when the bytes did not decode).
    pub item: Option<ItemRef>,
    /// Why.
    pub reason: RejectReason,
}

/// A pending transaction's place in a mempool.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pending {
    arrival: u64,
    sender: RobotId,
    nonce: u64,
    /// When it entered the mempool (not part of the node's digest: the pending block's
    /// recommit, [`super::Ledger::pending_state`], reads it).
    at: SimTime,
}

/// A node's pending transactions, indexed the three ways the ledger and the gossip read them:
/// by id (with the arrival number at this node), by arrival, and by sender then nonce. The
/// indexes are kept together so that no reader rebuilds one per call; each is one flat map,
/// so a mempool of many senders costs no allocation per sender.
#[derive(Clone, Debug, Default)]
pub(crate) struct Mempool {
    by_id: BTreeMap<TxHash, Pending>,
    by_arrival: BTreeMap<u64, TxHash>,
    /// (sender, nonce, id).
    by_sender: BTreeSet<(RobotId, u64, TxHash)>,
    /// Pending count per sender with pending transactions.
    counts: BTreeMap<RobotId, u32>,
    /// (pending count, sender) for every sender with pending transactions.
    load: BTreeSet<(u32, RobotId)>,
}

/// The lowest and highest ids, to bound ranges of `(sender, nonce, id)`.
const ID_MIN: TxHash = Digest([0; 32]);
const ID_MAX: TxHash = Digest([u8::MAX; 32]);

impl Mempool {
    /// Pending transactions.
    pub(crate) fn len(&self) -> usize {
        self.by_id.len()
    }

    /// Whether `hash` is pending.
    pub(crate) fn contains(&self, hash: &TxHash) -> bool {
        self.by_id.contains_key(hash)
    }

    /// The arrival number of a pending transaction.
    pub(crate) fn arrival(&self, hash: &TxHash) -> Option<u64> {
        self.by_id.get(hash).map(|p| p.arrival)
    }

    /// When a pending transaction entered the mempool.
    pub(crate) fn arrived_at(&self, hash: &TxHash) -> Option<SimTime> {
        self.by_id.get(hash).map(|p| p.at)
    }

    /// (id, arrival number) in id order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (&TxHash, u64)> + '_ {
        self.by_id.iter().map(|(h, p)| (h, p.arrival))
    }

    /// (arrival number, id) of the transactions that arrived at or after `from`, in arrival
    /// order.
    pub(crate) fn arrived_from(&self, from: u64) -> impl Iterator<Item = (u64, TxHash)> + '_ {
        self.by_arrival.range(from..).map(|(a, h)| (*a, *h))
    }

    /// How many transactions `sender` has pending.
    pub(crate) fn count_of(&self, sender: RobotId) -> u32 {
        self.counts.get(&sender).copied().unwrap_or(0)
    }

    /// A sender's pending transactions as (nonce, id), in that order.
    pub(crate) fn of_sender(
        &self,
        sender: RobotId,
    ) -> impl DoubleEndedIterator<Item = (u64, TxHash)> + '_ {
        self.by_sender
            .range((sender, 0, ID_MIN)..=(sender, u64::MAX, ID_MAX))
            .map(|&(_, nonce, hash)| (nonce, hash))
    }

    /// The pending transaction of `sender` with `nonce` and the lowest id, if any.
    pub(crate) fn lowest_with_nonce(&self, sender: RobotId, nonce: u64) -> Option<TxHash> {
        self.by_sender
            .range((sender, nonce, ID_MIN)..=(sender, nonce, ID_MAX))
            .next()
            .map(|&(_, _, hash)| hash)
    }

    /// Every pending transaction as (sender, nonce, id), in that order.
    pub(crate) fn by_sender(&self) -> impl Iterator<Item = (RobotId, u64, TxHash)> + '_ {
        self.by_sender.iter().copied()
    }

    /// The sender with the most pending transactions (the highest id on ties) and its count.
    pub(crate) fn busiest(&self) -> Option<(RobotId, u32)> {
        self.load.last().map(|&(count, sender)| (sender, count))
    }

    fn set_count(&mut self, sender: RobotId, before: u32, after: u32) {
        if before > 0 {
            self.load.remove(&(before, sender));
        }
        if after > 0 {
            self.load.insert((after, sender));
            self.counts.insert(sender, after);
        } else {
            self.counts.remove(&sender);
        }
    }

    /// Adds a transaction that is not pending, arrived at `at`.
    pub(crate) fn insert(
        &mut self,
        hash: TxHash,
        sender: RobotId,
        nonce: u64,
        arrival: u64,
        at: SimTime,
    ) {
        let pending = Pending {
            arrival,
            sender,
            nonce,
            at,
        };
        let old = self.by_id.insert(hash, pending);
        assert!(old.is_none(), "a transaction enters a mempool twice");
        let fresh = self.by_arrival.insert(arrival, hash).is_none();
        assert!(fresh, "two pending transactions with one arrival number");
        self.by_sender.insert((sender, nonce, hash));
        let before = self.count_of(sender);
        self.set_count(sender, before, before + 1);
    }

    /// Removes a pending transaction; false if it was not pending.
    pub(crate) fn remove(&mut self, hash: &TxHash) -> bool {
        let Some(p) = self.by_id.remove(hash) else {
            return false;
        };
        self.by_arrival.remove(&p.arrival);
        self.by_sender.remove(&(p.sender, p.nonce, *hash));
        let before = self.count_of(p.sender);
        self.set_count(p.sender, before, before - 1);
        true
    }

    /// Keeps only the transactions whose nonce is at least their sender's `next[sender]`.
    pub(crate) fn retain_from_nonces(&mut self, next: &[u64]) {
        let stale: Vec<TxHash> = self
            .by_sender
            .iter()
            .filter(|(sender, nonce, _)| *nonce < next.get(*sender as usize).copied().unwrap_or(0))
            .map(|&(_, _, hash)| hash)
            .collect();
        for hash in stale {
            self.remove(&hash);
        }
    }

    /// Empties the mempool.
    pub(crate) fn clear(&mut self) {
        *self = Mempool::default();
    }
}

/// The latest transactions a node forgot, numbered from 0 in order (the gossip asks what a
/// peer forgot since it last looked). Keeps [`FORGET_LOG_KEPT`]; a reader that fell further
/// behind must assume anything was forgotten. Not part of the node's digest.
#[derive(Clone, Debug, Default)]
pub(crate) struct ForgetLog {
    /// The number of `txs[0]`.
    start: u64,
    txs: VecDeque<TxHash>,
}

/// Forgotten transactions a node's log keeps.
pub const FORGET_LOG_KEPT: usize = 64;

impl ForgetLog {
    pub(crate) fn push(&mut self, hash: TxHash) {
        self.txs.push_back(hash);
        if self.txs.len() > FORGET_LOG_KEPT {
            self.txs.pop_front();
            self.start += 1;
        }
    }

    /// The number the next forgotten transaction will get.
    pub(crate) fn end(&self) -> u64 {
        self.start + self.txs.len() as u64
    }

    /// The transactions forgotten from number `since` on, or None if the log no longer
    /// reaches back to it.
    pub(crate) fn since(&self, since: u64) -> Option<impl Iterator<Item = &TxHash> + '_> {
        let skip = since.checked_sub(self.start)?;
        (since <= self.end()).then(|| self.txs.iter().skip(skip as usize))
    }
}

/// One robot's node.
#[derive(Clone, Debug)]
pub struct Node {
    pub(crate) head: BlockHash,
    pub(crate) head_since: SimTime,
    /// The head's total difficulty (kept here: the gossip compares it for every pair).
    pub(crate) head_td: u64,
    /// The canonical chain by height: `canonical[h]` is the block at height h.
    pub(crate) canonical: Vec<BlockHash>,
    pub(crate) known_blocks: BTreeSet<BlockHash>,
    /// The known blocks by total difficulty (for the liveness rule of fork choice).
    pub(crate) by_td: BTreeMap<u64, Vec<BlockHash>>,
    /// How many transactions the node holds: pending in its mempool or carried by a block it
    /// knows. Which ones is one bit per node in each transaction's storage entry
    /// ([`super::TxEntry::held_by`]), so a node's index grows by a bit, not an id, per
    /// transaction; a replaced or evicted pending transaction leaves it.
    pub(crate) held_txs: u64,
    /// Pending transactions and their arrival sequence numbers at this node.
    pub(crate) mempool: Mempool,
    /// The next arrival number (it never decreases, not even at a restart).
    pub(crate) arrivals: u64,
    /// The transactions the node forgot: that left the refused set (its bound) while not
    /// held, so that [`super::Ledger::knows_tx`] turned false. An evicted or replaced
    /// transaction is not forgotten: it leaves the held ones for `refused_txs`.
    pub(crate) forgotten: ForgetLog,
    /// The latest rejections (at most [`super::MAX_REJECTIONS_KEPT`]).
    pub(crate) rejections: VecDeque<Rejection>,
    /// Rejections ever recorded.
    pub(crate) rejected_total: u64,
    /// Transactions refused recently (bounded, first in first out), so that a refused item
    /// is not examined again; they are not held, which admitted ones only are.
    pub(crate) refused_txs: BTreeSet<TxHash>,
    pub(crate) refused_order: VecDeque<TxHash>,
    /// Equivocation evidence: (signer, parent) -> two blocks the signer sealed on that parent
    /// (at most [`super::MAX_EVIDENCE`] entries).
    pub(crate) evidence: BTreeMap<(RobotId, BlockHash), (BlockHash, BlockHash)>,
    /// Pending transactions replaced (replacement rule) or evicted (global cap).
    pub(crate) mempool_replaced: u64,
    pub(crate) mempool_evicted: u64,
    /// Bumped on every change of what the node knows (gossip skips unchanged pairs).
    pub(crate) version: u64,
    pub(crate) reorgs: u64,
    pub(crate) deepest_reorg: u64,
    pub(crate) side_blocks: u64,
    /// Encoded bytes of every block the node holds, side branches included.
    pub(crate) stored_bytes: u64,
}

impl Node {
    pub(crate) fn new(genesis: BlockHash) -> Node {
        Node {
            head: genesis,
            head_since: SimTime(0),
            head_td: 0,
            canonical: vec![genesis],
            known_blocks: BTreeSet::from([genesis]),
            by_td: BTreeMap::from([(0, vec![genesis])]),
            held_txs: 0,
            mempool: Mempool::default(),
            arrivals: 0,
            forgotten: ForgetLog::default(),
            rejections: VecDeque::new(),
            rejected_total: 0,
            refused_txs: BTreeSet::new(),
            refused_order: VecDeque::new(),
            evidence: BTreeMap::new(),
            mempool_replaced: 0,
            mempool_evicted: 0,
            version: 0,
            reorgs: 0,
            deepest_reorg: 0,
            side_blocks: 0,
            stored_bytes: 0,
        }
    }

    /// The node's latest rejections, oldest first (at most [`super::MAX_REJECTIONS_KEPT`]).
    pub fn rejections(&self) -> Vec<&Rejection> {
        self.rejections.iter().collect()
    }

    /// Rejections ever recorded by the node.
    pub fn rejected_total(&self) -> u64 {
        self.rejected_total
    }

    /// Equivocation evidence held: (signer, parent) -> the two blocks it signed on the parent.
    pub fn evidence(&self) -> &BTreeMap<(RobotId, BlockHash), (BlockHash, BlockHash)> {
        &self.evidence
    }

    /// Pending transactions replaced by a lower id with the same nonce, and evicted by the
    /// global cap.
    pub fn mempool_churn(&self) -> (u64, u64) {
        (self.mempool_replaced, self.mempool_evicted)
    }

    /// Reorganisations of the canonical chain so far.
    pub fn reorgs(&self) -> u64 {
        self.reorgs
    }

    /// Blocks removed from the canonical chain by the deepest reorganisation.
    pub fn deepest_reorg(&self) -> u64 {
        self.deepest_reorg
    }

    /// Accepted blocks that did not extend the head when they arrived (side branches).
    pub fn side_blocks(&self) -> u64 {
        self.side_blocks
    }

    /// Encoded bytes of every block the node holds (side branches included, genesis not).
    pub fn stored_bytes(&self) -> u64 {
        self.stored_bytes
    }

    /// A digest of the node's view: head, mempool and counts.
    pub(crate) fn digest(&self, id: RobotId) -> Digest {
        // The bytes are gathered first and hashed at once: blake3 hashes a long input on
        // several lanes, but takes small updates one block at a time. Same bytes, same digest.
        let mut bytes = Vec::with_capacity(44 + 40 * self.mempool.len() + 88);
        bytes.extend_from_slice(&id.to_le_bytes());
        bytes.extend_from_slice(&self.head.0);
        bytes.extend_from_slice(&self.head_since.0.to_le_bytes());
        for (tx, arrival) in self.mempool.iter() {
            bytes.extend_from_slice(&tx.0);
            bytes.extend_from_slice(&arrival.to_le_bytes());
        }
        for n in [
            self.known_blocks.len() as u64,
            self.held_txs,
            self.rejected_total,
            self.evidence.len() as u64,
            self.mempool_replaced,
            self.mempool_evicted,
            self.version,
            self.reorgs,
            self.deepest_reorg,
            self.side_blocks,
            self.stored_bytes,
        ] {
            bytes.extend_from_slice(&n.to_le_bytes());
        }
        Digest::of(&bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{self, Purpose};

    /// A pending transaction in the plain model: (id, sender, nonce, arrival).
    type Plain = (TxHash, RobotId, u64, u64);

    /// The mempool's indexes against a plain list after every step.
    fn check(pool: &Mempool, plain: &[Plain]) {
        let mut by_id: Vec<(TxHash, u64)> = plain.iter().map(|p| (p.0, p.3)).collect();
        by_id.sort_unstable();
        let got: Vec<(TxHash, u64)> = pool.iter().map(|(h, a)| (*h, a)).collect();
        assert_eq!(got, by_id);
        for from in [0, 3, 10, 40] {
            let mut want: Vec<(u64, TxHash)> = plain
                .iter()
                .filter(|p| p.3 >= from)
                .map(|p| (p.3, p.0))
                .collect();
            want.sort_unstable();
            assert_eq!(pool.arrived_from(from).collect::<Vec<_>>(), want);
        }
        let mut by_sender: Vec<(RobotId, u64, TxHash)> =
            plain.iter().map(|p| (p.1, p.2, p.0)).collect();
        by_sender.sort_unstable();
        assert_eq!(pool.by_sender().collect::<Vec<_>>(), by_sender);
        let mut busiest = None;
        for sender in 0..5 {
            let mine: Vec<(u64, TxHash)> = by_sender
                .iter()
                .filter(|p| p.0 == sender)
                .map(|p| (p.1, p.2))
                .collect();
            assert_eq!(pool.count_of(sender) as usize, mine.len());
            assert_eq!(pool.of_sender(sender).collect::<Vec<_>>(), mine);
            for nonce in 0..6 {
                let lowest = mine.iter().find(|m| m.0 == nonce).map(|m| m.1);
                assert_eq!(pool.lowest_with_nonce(sender, nonce), lowest);
            }
            if !mine.is_empty() {
                busiest = busiest.max(Some((mine.len() as u32, sender)));
            }
        }
        assert_eq!(pool.busiest(), busiest.map(|(c, s)| (s, c)));
        assert_eq!(pool.len(), plain.len());
    }

    #[test]
    fn the_mempool_indexes_agree_with_a_plain_list() {
        let mut r = rng::stream(7, Purpose::Network, 0);
        let mut pool = Mempool::default();
        let mut plain: Vec<Plain> = Vec::new();
        let mut arrivals = 0;
        for step in 0..2000u64 {
            match r.below(10) {
                0..=5 => {
                    let hash = Digest::of(&step.to_le_bytes());
                    let (sender, nonce) = (r.below(5) as RobotId, r.below(6));
                    pool.insert(hash, sender, nonce, arrivals, SimTime(step));
                    plain.push((hash, sender, nonce, arrivals));
                    arrivals += 1;
                }
                6..=7 if !plain.is_empty() => {
                    let gone = plain.swap_remove(r.below(plain.len() as u64) as usize);
                    assert!(pool.remove(&gone.0));
                    assert!(!pool.remove(&gone.0));
                }
                8 => {
                    let next: Vec<u64> = (0..4).map(|_| r.below(4)).collect();
                    pool.retain_from_nonces(&next);
                    plain.retain(|p| p.2 >= next.get(p.1 as usize).copied().unwrap_or(0));
                }
                9 if r.chance(0.05) => {
                    pool.clear();
                    plain.clear();
                }
                _ => {}
            }
            check(&pool, &plain);
        }
    }
}

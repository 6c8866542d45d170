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
    /// The signer sealed one of the last floor(N/2) blocks of the chain.
    #[error("signer {0} signed recently")]
    RecentSigner(RobotId),
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

/// One robot's node.
#[derive(Clone, Debug)]
pub struct Node {
    pub(crate) head: BlockHash,
    pub(crate) head_since: SimTime,
    /// The canonical chain by height: `canonical[h]` is the block at height h.
    pub(crate) canonical: Vec<BlockHash>,
    pub(crate) known_blocks: BTreeSet<BlockHash>,
    /// The known blocks by total difficulty (for the liveness rule of fork choice).
    pub(crate) by_td: BTreeMap<u64, Vec<BlockHash>>,
    /// The transactions the node holds: pending in its mempool or carried by a block it
    /// knows. It grows with the chain (32 bytes per transaction, as geth's transaction index
    /// does); a replaced or evicted pending transaction leaves it.
    pub(crate) known_txs: BTreeSet<TxHash>,
    /// Pending transactions and their arrival sequence numbers at this node.
    pub(crate) mempool: BTreeMap<TxHash, u64>,
    pub(crate) arrivals: u64,
    /// The latest rejections (at most [`super::MAX_REJECTIONS_KEPT`]).
    pub(crate) rejections: VecDeque<Rejection>,
    /// Rejections ever recorded.
    pub(crate) rejected_total: u64,
    /// Transactions refused recently (bounded, first in first out), so that a refused item
    /// is not examined again; they are not `known_txs`, which holds admitted ones only.
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
    /// Remembers a refused, replaced or evicted transaction in the bounded refused set (first
    /// in, first out), so that it is not examined again while it is there.
    pub(crate) fn remember_refused(&mut self, hash: TxHash) {
        if self.refused_txs.insert(hash) {
            self.refused_order.push_back(hash);
            if self.refused_order.len() > super::MAX_REFUSED_KEPT {
                let old = self.refused_order.pop_front().expect("not empty");
                self.refused_txs.remove(&old);
            }
        }
    }

    pub(crate) fn new(genesis: BlockHash) -> Node {
        Node {
            head: genesis,
            head_since: SimTime(0),
            canonical: vec![genesis],
            known_blocks: BTreeSet::from([genesis]),
            by_td: BTreeMap::from([(0, vec![genesis])]),
            known_txs: BTreeSet::new(),
            mempool: BTreeMap::new(),
            arrivals: 0,
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
        let mut h = blake3::Hasher::new();
        h.update(&id.to_le_bytes());
        h.update(&self.head.0);
        h.update(&self.head_since.0.to_le_bytes());
        for (tx, arrival) in &self.mempool {
            h.update(&tx.0);
            h.update(&arrival.to_le_bytes());
        }
        for n in [
            self.known_blocks.len() as u64,
            self.known_txs.len() as u64,
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
            h.update(&n.to_le_bytes());
        }
        h.finalize().into()
    }
}

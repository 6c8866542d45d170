//! What a node may seal: Clique's signer rules (the recent-signer rule, the sealers removed
//! by evidence, the in-turn difficulty), and the evidence and transactions a block sealed on
//! its head now carries.

use super::{block, evidence, BlockEntry, BlockHash, Evidence, Ledger, TxHash, MAX_BLOCK_BYTES};
use crate::types::{RobotId, SimTime};

impl Ledger {
    /// Clique's recent-signer rule: whether `signer` sealed one of the last floor(S/2) blocks
    /// of the chain ending at `parent` (so that it may not seal a child of `parent`). False
    /// when `parent` is not stored.
    pub fn signed_recently(&self, parent: &BlockHash, signer: RobotId) -> bool {
        self.blocks.get(parent).is_some_and(|entry| {
            entry
                .recent_signers
                .get((signer / 64) as usize)
                .is_some_and(|word| word & (1u64 << (signer % 64)) != 0)
        })
    }

    /// Whether `signer` is removed from the signer set on the chain ending at `parent` (so
    /// that it may not seal a child of `parent`). False when `parent` is not stored.
    pub fn removed_at(&self, parent: &BlockHash, signer: RobotId) -> bool {
        self.blocks
            .get(parent)
            .is_some_and(|e| evidence::bits::has(&e.removed_signers, signer))
    }

    /// The sealers removed from the signer set on the chain ending at `block`, ascending
    /// (empty when `block` is not stored).
    pub fn removed_signers(&self, block: &BlockHash) -> Vec<RobotId> {
        self.blocks.get(block).map_or_else(Vec::new, |e| {
            (0..self.robots)
                .filter(|&r| evidence::bits::has(&e.removed_signers, r))
                .collect()
        })
    }

    /// How many signers are authorised for the children of `entry` (all robots but the
    /// removed ones).
    pub(crate) fn signers_after(&self, entry: &BlockEntry) -> u32 {
        self.robots - evidence::bits::count(&entry.removed_signers)
    }

    /// The difficulty a child of `parent` sealed by `signer` must have: 2 in turn, 1
    /// otherwise. In turn at height h is the (h mod S)-th of the S authorised signers in id
    /// order (Clique's rule); with nobody removed, the robot h mod N. A parent not stored
    /// counts as one where nobody is removed.
    pub fn expected_difficulty(&self, parent: &BlockHash, signer: RobotId) -> u64 {
        match self.blocks.get(parent) {
            Some(entry) => self.difficulty_after(entry, signer),
            None => self.difficulty_in_turn(1, signer, None),
        }
    }

    /// [`Ledger::expected_difficulty`] of a child of the stored `parent`.
    pub(crate) fn difficulty_after(&self, parent: &BlockEntry, signer: RobotId) -> u64 {
        let height = parent.block.header.height + 1;
        self.difficulty_in_turn(height, signer, Some(&parent.removed_signers))
    }

    pub(crate) fn difficulty_in_turn(
        &self,
        height: u64,
        signer: RobotId,
        removed: Option<&[u64]>,
    ) -> u64 {
        let removed = removed.filter(|r| r.iter().any(|w| *w != 0));
        let in_turn = match removed {
            None => height % u64::from(self.robots) == u64::from(signer),
            Some(removed) => {
                let signers = self.robots - evidence::bits::count(removed);
                let k = (height % u64::from(signers.max(1))) as u32;
                evidence::bits::nth_absent(removed, self.robots, k) == Some(signer)
            }
        };
        if in_turn {
            2
        } else {
            1
        }
    }

    /// Whether `node` may seal a child of `parent` under Clique's rules: it is still a signer
    /// there and did not sign recently.
    pub fn may_seal_on(&self, parent: &BlockHash, node: RobotId) -> bool {
        !self.signed_recently(parent, node) && !self.removed_at(parent, node)
    }

    /// The evidence `node` would carry in a block sealed on its head now: each pair of twin
    /// blocks it holds as evidence ([`Node::evidence`], in (signer, parent) order) against a
    /// sealer other than itself that is still a signer at its head, whose parent is on its
    /// canonical chain no more than [`evidence::MAX_EVIDENCE_AGE_BLOCKS`] below the new
    /// block; one per sealer, at most [`evidence::MAX_BLOCK_EVIDENCE`].
    ///
    /// [`Node::evidence`]: super::Node::evidence
    pub fn sealable_evidence(&self, node: RobotId) -> Vec<(BlockHash, BlockHash)> {
        let n = self.node(node);
        let head = &self.blocks[&n.head];
        let height = n.canonical.len() as u64;
        let mut out: Vec<(BlockHash, BlockHash)> = Vec::new();
        let mut last_signer = None;
        for ((signer, parent), pair) in &n.evidence {
            if out.len() == evidence::MAX_BLOCK_EVIDENCE {
                break;
            }
            if *signer == node
                || last_signer == Some(*signer)
                || evidence::bits::has(&head.removed_signers, *signer)
            {
                continue;
            }
            let Some(p) = self.blocks.get(parent) else {
                continue;
            };
            let parent_height = p.block.header.height;
            let on_chain = n.canonical.get(parent_height as usize) == Some(parent);
            if !on_chain || height - (parent_height + 1) > evidence::MAX_EVIDENCE_AGE_BLOCKS {
                continue;
            }
            last_signer = Some(*signer);
            out.push(*pair);
        }
        out
    }

    /// The proofs of the twin pairs `pairs` (stored blocks), in order; None for a pair that is
    /// not an equivocation.
    pub(crate) fn evidence_of(&self, pairs: &[(BlockHash, BlockHash)]) -> Option<Vec<Evidence>> {
        pairs
            .iter()
            .map(|(a, b)| {
                let (a, b) = (self.blocks.get(a)?, self.blocks.get(b)?);
                Evidence::of(&a.block.header, &b.block.header)
            })
            .collect()
    }

    /// The node's pending transactions that a block on its head may include, in execution
    /// order: per sender the run of consecutive nonces from the next expected one (a duplicate
    /// nonce: the lowest id), senders interleaved by arrival at the node. At most
    /// [`block::MAX_BLOCK_TXS`].
    pub fn sealable_txs(&self, node: RobotId) -> Vec<TxHash> {
        self.sealable_txs_until(node, None)
    }

    /// [`Ledger::sealable_txs`] from the node's mempool as it was at `until` (the transactions
    /// that entered it later left out, as if not yet arrived); the whole mempool with None.
    pub(crate) fn sealable_txs_until(&self, node: RobotId, until: Option<SimTime>) -> Vec<TxHash> {
        let n = self.node(node);
        let arrived = |hash: &TxHash| {
            until.is_none_or(|t| n.mempool.arrived_at(hash).is_some_and(|a| a <= t))
        };
        let next = &self.blocks[&n.head].next_nonce;
        // Per sender (in id order), the run of consecutive nonces from the next expected one.
        let mut runs: Vec<std::collections::VecDeque<(u64, TxHash)>> = Vec::new();
        let mut current: Option<(RobotId, u64, bool)> = None;
        for (sender, nonce, hash) in n.mempool.by_sender() {
            let (_, expected, open) = match &mut current {
                Some(c) if c.0 == sender => c,
                _ => {
                    runs.push(std::collections::VecDeque::new());
                    current.insert((sender, next[sender as usize], true))
                }
            };
            if !*open {
                continue;
            }
            if nonce == *expected && !arrived(&hash) {
                // Not there yet: the sender's run stops as at a gap.
                *open = false;
            } else if nonce == *expected {
                let arrival = n.mempool.arrival(&hash).expect("indexed as pending");
                runs.last_mut().expect("pushed").push_back((arrival, hash));
                *expected += 1;
            } else if nonce > *expected {
                *open = false;
            }
        }
        runs.retain(|run| !run.is_empty());
        let mut out = Vec::new();
        // Header bytes: a generous bound on the encoded header (about 170 bytes), plus the
        // evidence the block will carry.
        let mut bytes = 256u64
            + self
                .evidence_of(&self.sealable_evidence(node))
                .map_or(0, |ev| ev.iter().map(|e| e.size_bytes() + 8).sum());
        while out.len() < block::MAX_BLOCK_TXS {
            let best = runs
                .iter()
                .enumerate()
                .filter_map(|(i, r)| r.front().map(|f| (f.0, i)))
                .min();
            let Some((_, i)) = best else { break };
            let hash = runs[i].pop_front().expect("front exists").1;
            let size = u64::from(self.txs[&hash].size_bytes);
            if bytes + size > MAX_BLOCK_BYTES {
                // The rest of this sender's run waits for the next block (nonce order).
                runs[i].clear();
                continue;
            }
            bytes += size;
            out.push(hash);
        }
        out
    }
}

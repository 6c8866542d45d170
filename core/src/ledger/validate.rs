//! The rules: which events the reducer can apply at all, and whether a block is valid against
//! its parent (header rules, signature, body limits, nonces, execution).

use std::collections::BTreeMap;
use std::sync::Arc;

use super::evidence::{bits, MAX_BLOCK_EVIDENCE, MAX_EVIDENCE_AGE_BLOCKS};
use super::{
    block, Block, BlockEntry, BlockHash, BlockHeader, ItemRef, Ledger, LedgerError, LedgerEvent,
    RejectReason, TxEntry, TxHash, MAX_BLOCK_BYTES,
};
use crate::types::RobotId;

impl Ledger {
    /// Every check that can make an event an error, before anything changes.
    pub(super) fn check_event(&self, event: &LedgerEvent) -> Result<(), LedgerError> {
        let node_ok = |node: RobotId| {
            if node < self.robots {
                Ok(())
            } else {
                Err(LedgerError::UnknownNode {
                    node,
                    robots: self.robots,
                })
            }
        };
        match event {
            LedgerEvent::Submit { tx } => node_ok(tx.sender),
            LedgerEvent::Seal {
                node,
                parent,
                txs,
                evidence,
            } => {
                node_ok(*node)?;
                let n = self.node(*node);
                for (a, b) in evidence {
                    let held = self.blocks.get(a).is_some_and(|e| {
                        let h = &e.block.header;
                        n.evidence.get(&(h.signer, h.parent)) == Some(&(*a, *b))
                    });
                    if !held {
                        return Err(LedgerError::UnknownItem {
                            node: *node,
                            item: ItemRef::Block(*b),
                        });
                    }
                }
                if *parent != n.head {
                    return Err(LedgerError::SealNotOnHead {
                        node: *node,
                        parent: *parent,
                        head: n.head,
                    });
                }
                for h in txs {
                    if !self.holds_tx(*node, h) {
                        return Err(LedgerError::UnknownItem {
                            node: *node,
                            item: ItemRef::Tx(*h),
                        });
                    }
                }
                Ok(())
            }
            LedgerEvent::Send {
                from, to, items, ..
            } => {
                node_ok(*from)?;
                node_ok(*to)?;
                if from == to || items.is_empty() {
                    return Err(LedgerError::BadMessage {
                        from: *from,
                        to: *to,
                        why: "a message goes to another node and carries at least one item".into(),
                    });
                }
                let n = self.node(*from);
                for item in items {
                    let known = match item {
                        ItemRef::Block(h) => n.known_blocks.contains(h),
                        ItemRef::Tx(h) => self.holds_tx(*from, h),
                    };
                    if !known {
                        return Err(LedgerError::UnknownItem {
                            node: *from,
                            item: *item,
                        });
                    }
                }
                Ok(())
            }
            LedgerEvent::Deliver { message } => {
                if self.flights.contains_key(message) {
                    Ok(())
                } else {
                    Err(LedgerError::UnknownMessage { message: *message })
                }
            }
            LedgerEvent::Inject { node, .. } | LedgerEvent::Restart { node } => node_ok(*node),
        }
    }

    /// The checks of a header against its parent that need no body: signer, height,
    /// timestamp, difficulty, recent signers, then the signature. Cheap (one signature check)
    /// and done before any work on the body.
    pub(super) fn validate_header(
        &self,
        header: &BlockHeader,
    ) -> Result<&BlockEntry, RejectReason> {
        let parent = self
            .blocks
            .get(&header.parent)
            .ok_or(RejectReason::UnknownParent(header.parent))?;
        let ph = &parent.block.header;
        if header.signer >= self.robots {
            return Err(RejectReason::UnauthorisedSigner(header.signer));
        }
        if header.height != ph.height + 1 {
            return Err(RejectReason::BadHeight {
                got: header.height,
                expected: ph.height + 1,
            });
        }
        let earliest_ms = ph.timestamp_ms + self.period_ms;
        if header.timestamp_ms < earliest_ms {
            return Err(RejectReason::TooEarly {
                got_ms: header.timestamp_ms,
                earliest_ms,
            });
        }
        let expected = self.difficulty_after(parent, header.signer);
        if header.difficulty != expected {
            return Err(RejectReason::BadDifficulty {
                got: header.difficulty,
                expected,
            });
        }
        if bits::has(&parent.removed_signers, header.signer) {
            return Err(RejectReason::RemovedSigner(header.signer));
        }
        if self.signed_recently(&header.parent, header.signer) {
            return Err(RejectReason::RecentSigner(header.signer));
        }
        if header.evidence.len() > MAX_BLOCK_EVIDENCE {
            return Err(RejectReason::Malformed(format!(
                "{} evidence entries, more than the {MAX_BLOCK_EVIDENCE} allowed",
                header.evidence.len()
            )));
        }
        if !self
            .keys
            .verify(header.signer, &header.signing_hash(), &header.signature)
        {
            return Err(RejectReason::BadSignature);
        }
        self.check_evidence(header, parent)?;
        Ok(parent)
    }

    /// The evidence a header carries, on the chain ending at its (stored) parent: each proof
    /// verifies alone, accuses another sealer than the block's, one still a signer here and
    /// not accused twice, and names as parent a block of this chain at most
    /// [`MAX_EVIDENCE_AGE_BLOCKS`] below the new block (which binds the proof to the chain).
    pub(super) fn check_evidence(
        &self,
        header: &BlockHeader,
        parent: &BlockEntry,
    ) -> Result<(), RejectReason> {
        let mut accused = Vec::new();
        for (i, ev) in header.evidence.iter().enumerate() {
            let bad = |why: String| Err(RejectReason::BadEvidence(format!("entry {i}: {why}")));
            if let Err(why) = ev.verify(&self.keys) {
                return bad(why);
            }
            if ev.signer == header.signer {
                return bad("a sealer does not carry evidence against itself".into());
            }
            if bits::has(&parent.removed_signers, ev.signer) || accused.contains(&ev.signer) {
                return bad(format!("signer {} is already removed", ev.signer));
            }
            if ev.height > header.height || header.height - ev.height > MAX_EVIDENCE_AGE_BLOCKS {
                return bad(format!(
                    "an equivocation at height {} cannot be proven at height {} (at most {} \
                     blocks back)",
                    ev.height, header.height, MAX_EVIDENCE_AGE_BLOCKS
                ));
            }
            if self.ancestor_at(&header.parent, ev.height - 1) != Some(ev.parent) {
                return bad("its parent is not on this chain".into());
            }
            accused.push(ev.signer);
        }
        Ok(())
    }

    /// The block at `height` on the chain ending at the stored `from`, by a walk down.
    fn ancestor_at(&self, from: &BlockHash, height: u64) -> Option<BlockHash> {
        let mut cursor = *from;
        loop {
            let h = &self.blocks.get(&cursor)?.block.header;
            if h.height == height {
                return Some(cursor);
            }
            if h.height < height {
                return None;
            }
            cursor = h.parent;
        }
    }

    /// The removed signers after a block on `parent` carrying `header`'s evidence: the
    /// parent's, plus the accused (shared with the parent when there is no evidence).
    pub(super) fn removed_after(&self, parent: &BlockEntry, header: &BlockHeader) -> Arc<[u64]> {
        if header.evidence.is_empty() {
            return parent.removed_signers.clone();
        }
        let mut set = parent.removed_signers.to_vec();
        for ev in &header.evidence {
            bits::add(&mut set, ev.signer);
        }
        set.into()
    }

    /// Validates a block against its parent: header rules and signature first, then the body
    /// (root, count, byte limit, each transaction stored or in `fresh`, intrinsically valid,
    /// with the next nonce of its sender) and execution. Pure.
    pub(super) fn validate(
        &self,
        header: &BlockHeader,
        txs: &[TxHash],
        fresh: &BTreeMap<TxHash, TxEntry>,
    ) -> Result<BlockEntry, RejectReason> {
        let parent = self.validate_header(header)?;
        let ph = &parent.block.header;
        let removed_signers = self.removed_after(parent, header);
        let signers = self.robots - bits::count(&removed_signers);
        if txs.len() > block::MAX_BLOCK_TXS {
            return Err(RejectReason::Malformed(format!(
                "{} transactions, more than the {} allowed",
                txs.len(),
                block::MAX_BLOCK_TXS
            )));
        }
        if header.tx_root != block::tx_root(txs) {
            return Err(RejectReason::BadTxRoot);
        }
        let mut size_bytes = u64::from(header.hash_and_size().1);
        for hash in txs {
            size_bytes += self
                .txs
                .get(hash)
                .or_else(|| fresh.get(hash))
                .map_or(0, |e| u64::from(e.size_bytes));
        }
        if size_bytes > MAX_BLOCK_BYTES {
            return Err(RejectReason::Oversize {
                bytes: size_bytes,
                limit: MAX_BLOCK_BYTES,
            });
        }
        let mut state = parent.state.clone();
        let epoch = self.enter_block(&mut state, ph.timestamp_ms, header.timestamp_ms);
        let params = &self.epochs[epoch].params;
        let mut next_nonce = parent.next_nonce.to_vec();
        let mut receipts = Vec::with_capacity(txs.len());
        for (index, hash) in txs.iter().enumerate() {
            let bad = |reason| RejectReason::BadTx {
                index: index as u32,
                reason: Box::new(reason),
            };
            let entry = self
                .txs
                .get(hash)
                .or_else(|| fresh.get(hash))
                .ok_or_else(|| bad(RejectReason::Malformed("unknown transaction".into())))?;
            entry.intrinsic.clone().map_err(bad)?;
            let tx = &entry.tx;
            let expected = next_nonce[tx.sender as usize];
            if tx.nonce < expected {
                return Err(bad(RejectReason::ReplayedNonce {
                    nonce: tx.nonce,
                    expected,
                }));
            }
            if tx.nonce > expected {
                return Err(bad(RejectReason::NonceGap {
                    nonce: tx.nonce,
                    expected,
                }));
            }
            next_nonce[tx.sender as usize] += 1;
            receipts.push(tx.execute_on(&mut state, params));
        }
        Ok(BlockEntry {
            block: Arc::new(Block {
                header: header.clone(),
                txs: txs.to_vec(),
            }),
            size_bytes,
            total_difficulty: parent.total_difficulty + header.difficulty,
            chain_bytes: parent.chain_bytes + size_bytes,
            state_digest: state.digest(),
            state,
            recent_signers: self.recent_signers_after(&header.parent, header.signer, signers),
            removed_signers,
            next_nonce: next_nonce.into(),
            receipts: receipts.into(),
            children: 0,
        })
    }

    /// The recent signers (see [`BlockEntry::recent_signers`]) of a block sealed by `signer`
    /// on the stored block `parent`, with `signers` authorised signers after it: the signer
    /// itself and the signers of the floor(signers/2) - 1 blocks of the chain ending at
    /// `parent`, genesis excluded. Walks the ancestors once per new block.
    fn recent_signers_after(
        &self,
        parent: &BlockHash,
        signer: RobotId,
        signers: u32,
    ) -> Arc<[u64]> {
        let mut bits = vec![0u64; self.robots.div_ceil(64) as usize];
        let mut set = |s: RobotId| {
            if let Some(word) = bits.get_mut((s / 64) as usize) {
                *word |= 1u64 << (s % 64);
            }
        };
        let limit = signers / 2;
        if limit > 0 {
            set(signer);
        }
        let mut cursor = *parent;
        for _ in 1..limit {
            let Some(entry) = self.blocks.get(&cursor) else {
                break;
            };
            let header = &entry.block.header;
            if header.height == 0 {
                break;
            }
            set(header.signer);
            cursor = header.parent;
        }
        bits.into()
    }
}

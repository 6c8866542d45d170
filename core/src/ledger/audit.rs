//! Checks from scratch, without any cache: the contract state of a chain re-executed, one
//! block against every rule, a node's whole canonical chain. Tests and `inspect` use them to
//! confirm that the cached results are what a fresh verification gives.

use super::evidence::bits;
use super::{block, BlockEntry, BlockHash, Ledger, MAX_BLOCK_BYTES};
use crate::contract::ContractState;
use crate::types::RobotId;

impl Ledger {
    /// Re-derives the contract state of a chain (genesis first) from scratch, without any
    /// cache: every transaction executed again in order.
    pub fn replay_state(&self, chain: &[BlockHash]) -> Result<ContractState, String> {
        let mut state = ContractState::genesis(self.params());
        let mut parent_ms = 0;
        for (i, hash) in chain.iter().enumerate() {
            let entry = self
                .blocks
                .get(hash)
                .ok_or_else(|| format!("block {i} ({hash:?}) is not stored"))?;
            let timestamp_ms = entry.block.header.timestamp_ms;
            let params = &self.epochs[self.enter_block(&mut state, parent_ms, timestamp_ms)].params;
            parent_ms = timestamp_ms;
            for tx in &entry.block.txs {
                let tx = &self
                    .txs
                    .get(tx)
                    .ok_or_else(|| format!("transaction {tx:?} is not stored"))?
                    .tx;
                tx.execute_on(&mut state, params);
            }
        }
        Ok(state)
    }

    /// Checks one stored block against its parent from scratch, without any cache: linkage,
    /// every Clique rule, the signatures (verified again), the byte and count limits, the
    /// transaction root, the nonces, and the contract state after it against a fresh
    /// execution of its transactions on the parent's state (which conserves tokens).
    pub fn check_block(&self, hash: &BlockHash) -> Result<(), String> {
        let entry = self
            .blocks
            .get(hash)
            .ok_or_else(|| format!("block {hash:?} is not stored"))?;
        let h = &entry.block.header;
        if h.height == 0 {
            return if *hash == self.genesis {
                Ok(())
            } else {
                Err("a second genesis".into())
            };
        }
        let fail = |what: &str| format!("block {} at height {}: {what}", hash.short(), h.height);
        let parent = self
            .blocks
            .get(&h.parent)
            .ok_or_else(|| fail("parent not stored"))?;
        self.check_header_afresh(hash, entry, parent)
            .and_then(|()| self.check_body_afresh(entry, parent))
            .map_err(fail)
    }

    /// The header half of [`Ledger::check_block`]: linkage, signer and signature, period,
    /// the signer still in the signer set, difficulty, the recent-signer rule, the evidence
    /// (verified again) and the removed signers after it, and the cached recent signers
    /// against a walk of the block's own chain. The parent's removed signers are taken from
    /// its entry (checked in turn when the parent is).
    fn check_header_afresh(
        &self,
        hash: &BlockHash,
        entry: &BlockEntry,
        parent: &BlockEntry,
    ) -> Result<(), &'static str> {
        let h = &entry.block.header;
        let ph = &parent.block.header;
        if h.height != ph.height + 1 || h.hash_and_size().0 != *hash {
            return Err("broken linkage");
        }
        if h.signer >= self.robots || !self.keys.verify(h.signer, &h.signing_hash(), &h.signature) {
            return Err("bad signer or signature");
        }
        if h.timestamp_ms < ph.timestamp_ms + self.period_ms {
            return Err("sealed before the period elapsed");
        }
        if bits::has(&parent.removed_signers, h.signer) {
            return Err("a removed signer sealed");
        }
        if h.difficulty != self.difficulty_after(parent, h.signer) {
            return Err("wrong difficulty");
        }
        if self.check_evidence(h, parent).is_err() {
            return Err("bad equivocation evidence");
        }
        let mut removed = parent.removed_signers.to_vec();
        for ev in &h.evidence {
            bits::add(&mut removed, ev.signer);
        }
        if removed[..] != entry.removed_signers[..] {
            return Err("cached removed signers differ from the chain's evidence");
        }
        let mut cursor = h.parent;
        for _ in 0..self.signers_after(parent) / 2 {
            let c = &self.blocks[&cursor].block.header;
            if c.height == 0 {
                break;
            }
            if c.signer == h.signer {
                return Err("recent signer sealed again");
            }
            cursor = c.parent;
        }
        // The cached recent signers against a walk of the block's own chain.
        let mut recent = vec![0u64; self.robots.div_ceil(64) as usize];
        let mut cursor = *hash;
        for _ in 0..self.signers_after(entry) / 2 {
            let c = &self.blocks[&cursor].block.header;
            if c.height == 0 {
                break;
            }
            if let Some(word) = recent.get_mut((c.signer / 64) as usize) {
                *word |= 1u64 << (c.signer % 64);
            }
            cursor = c.parent;
        }
        if recent[..] != entry.recent_signers[..] {
            return Err("cached recent signers differ from the chain's");
        }
        Ok(())
    }

    /// The body half of [`Ledger::check_block`]: transaction root, limits, each transaction's
    /// signature and nonce, and the state, nonces and total difficulty after a fresh
    /// execution on the parent's state.
    fn check_body_afresh(
        &self,
        entry: &BlockEntry,
        parent: &BlockEntry,
    ) -> Result<(), &'static str> {
        let h = &entry.block.header;
        let ph = &parent.block.header;
        if h.tx_root != block::tx_root(&entry.block.txs) {
            return Err("transaction root mismatch");
        }
        if entry.block.txs.len() > block::MAX_BLOCK_TXS || entry.size_bytes > MAX_BLOCK_BYTES {
            return Err("over the block limits");
        }
        let mut state = parent.state.clone();
        let epoch = self.enter_block(&mut state, ph.timestamp_ms, h.timestamp_ms);
        let params = &self.epochs[epoch].params;
        let mut nonces = parent.next_nonce.to_vec();
        for tx in &entry.block.txs {
            let Some(stored) = self.txs.get(tx) else {
                return Err("transaction not stored");
            };
            let tx = &stored.tx;
            if tx.sender >= self.robots
                || !tx.signature_ok(&self.keys)
                || tx.nonce != nonces[tx.sender as usize]
            {
                return Err("bad transaction signature or nonce");
            }
            nonces[tx.sender as usize] += 1;
            tx.execute_on(&mut state, params);
        }
        if state.digest() != entry.state.digest()
            || entry.state_digest != entry.state.digest()
            || nonces[..] != entry.next_nonce[..]
        {
            return Err("contract state differs from a fresh execution");
        }
        if entry.total_difficulty != parent.total_difficulty + h.difficulty {
            return Err("total difficulty");
        }
        Ok(())
    }

    /// Checks a node's canonical chain from scratch: linkage, every Clique rule (with the
    /// signer set shrunk by the evidence the chain carries), every signature (verified again,
    /// not from the cache), nonces, transaction roots, and the contract state after every
    /// block against a fresh re-execution.
    pub fn check_chain(&self, node: RobotId) -> Result<(), String> {
        let chain = self.canonical_chain(node);
        if chain.first() != Some(&self.genesis) {
            return Err("the chain does not start at genesis".into());
        }
        if chain.last() != Some(&self.node(node).head) {
            return Err("the chain does not end at the head".into());
        }
        let mut state = ContractState::genesis(self.params());
        let mut nonces = vec![0u64; self.robots as usize];
        let mut td = 0u64;
        let mut recent: Vec<RobotId> = Vec::new();
        let mut removed = vec![0u64; self.robots.div_ceil(64) as usize];
        for (height, pair) in chain.windows(2).enumerate() {
            let height = height as u64 + 1;
            let (parent, child) = (&self.blocks[&pair[0]], &self.blocks[&pair[1]]);
            let h = &child.block.header;
            let fail = |what: &str| Err(format!("node {node}, height {height}: {what}"));
            if h.parent != pair[0] || h.height != height || h.hash_and_size().0 != pair[1] {
                return fail("broken linkage");
            }
            if h.signer >= self.robots
                || !self.keys.verify(h.signer, &h.signing_hash(), &h.signature)
            {
                return fail("bad signer or signature");
            }
            if h.timestamp_ms < parent.block.header.timestamp_ms + self.period_ms {
                return fail("sealed before the period elapsed");
            }
            if bits::has(&removed, h.signer) {
                return fail("a removed signer sealed");
            }
            if h.difficulty != self.difficulty_in_turn(height, h.signer, Some(&removed)) {
                return fail("wrong difficulty");
            }
            let window = ((self.robots - bits::count(&removed)) / 2) as usize;
            if recent.iter().rev().take(window).any(|&s| s == h.signer) {
                return fail("recent signer sealed again");
            }
            recent.push(h.signer);
            for ev in &h.evidence {
                if ev.verify(&self.keys).is_err()
                    || ev.signer == h.signer
                    || bits::has(&removed, ev.signer)
                    || ev.height > height
                    || height - ev.height > super::evidence::MAX_EVIDENCE_AGE_BLOCKS
                    || chain.get(ev.height as usize - 1) != Some(&ev.parent)
                {
                    return fail("bad equivocation evidence");
                }
                bits::add(&mut removed, ev.signer);
            }
            if removed[..] != child.removed_signers[..] {
                return fail("removed signers differ from the chain's evidence");
            }
            if h.tx_root != block::tx_root(&child.block.txs) {
                return fail("transaction root mismatch");
            }
            let epoch =
                self.enter_block(&mut state, parent.block.header.timestamp_ms, h.timestamp_ms);
            let params = &self.epochs[epoch].params;
            for tx in &child.block.txs {
                let tx = &self.txs[tx].tx;
                if !tx.signature_ok(&self.keys) || tx.nonce != nonces[tx.sender as usize] {
                    return fail("bad transaction signature or nonce");
                }
                nonces[tx.sender as usize] += 1;
                tx.execute_on(&mut state, params);
            }
            td += h.difficulty;
            if td != child.total_difficulty || state.digest() != child.state.digest() {
                return fail("total difficulty or contract state differs from a fresh replay");
            }
        }
        Ok(())
    }
}

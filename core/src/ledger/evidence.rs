//! Equivocation evidence and the signer set it shrinks (docs/SPEC.md, "Equivocation").
//!
//! An equivocation is two different headers signed by one sealer on one parent. A node that
//! knows both blocks keeps the pair ([`super::Node::evidence`]); when it seals, it carries the
//! proof in its block's header ([`Evidence`]: both signed headers, minus what they share). The
//! block removes the sealer from the signer set of its chain: every node that applies the
//! block agrees, since the proof verifies from the block alone (two signatures) and the set
//! is a function of the chain ([`super::BlockEntry::removed_signers`]). As in Clique:
//! - *in-turn order*: the sealer in turn at height `h` is the `(h mod S)`-th authorised signer
//!   in id order, with `S` the number of signers left (all `N` robots until a removal);
//! - *recent signers*: a signer may seal at most one of every `floor(S/2) + 1` consecutive
//!   blocks (the window shrinks with the set);
//! - *quorum*: none is needed. Clique removes a signer by the votes of more than half of the
//!   signers, because a vote is an opinion; evidence is a proof any node checks, so one block
//!   suffices (as a slashing proof does in Ethereum's beacon chain);
//! - *fork choice* is unchanged (the greatest total difficulty): a branch without the
//!   evidence still accepts the sealer's blocks, but the honest sealers, who carry the
//!   evidence as soon as they hold it, make the heavier chain;
//! - *history* stays: the blocks the sealer made before the removal (the twins included)
//!   remain valid, and its account keeps its tokens (removal from the signer set is not a
//!   removal from learning).
//!
//! A sealer never carries evidence against itself, so a block always leaves at least its own
//! signer in the set: the set never empties.

pub use super::block::{evidence_root, Evidence, SignedHalf};
use super::block::{BlockHeader, UnsignedHeader};
use super::keys::Keys;
use crate::types::Digest;

/// Most evidence entries one block may carry (more is malformed); a node carries the oldest
/// ones first.
pub const MAX_BLOCK_EVIDENCE: usize = 8;

/// How far back (in blocks) the parent of an equivocation may lie below the block that carries
/// its evidence; older evidence is refused (it bounds the walk that binds the proof to the
/// chain). 1024 blocks are almost three hours at the paper's 10 s period.
pub const MAX_EVIDENCE_AGE_BLOCKS: u64 = 1024;

impl SignedHalf {
    fn of(header: &BlockHeader) -> SignedHalf {
        SignedHalf {
            timestamp_ms: header.timestamp_ms,
            difficulty: header.difficulty,
            tx_root: header.tx_root,
            evidence_root: evidence_root(&header.evidence),
            signature: header.signature,
        }
    }
}

impl Evidence {
    /// The evidence of two headers by one signer on one parent (in either order); None when
    /// they are not an equivocation (another signer or parent, or the same signed content).
    pub fn of(a: &BlockHeader, b: &BlockHeader) -> Option<Evidence> {
        if a.signer != b.signer || a.parent != b.parent || a.height != b.height {
            return None;
        }
        let (ha, hb) = (a.signing_hash(), b.signing_hash());
        let (first, second) = match ha.cmp(&hb) {
            std::cmp::Ordering::Less => (a, b),
            std::cmp::Ordering::Greater => (b, a),
            std::cmp::Ordering::Equal => return None,
        };
        Some(Evidence {
            signer: a.signer,
            parent: a.parent,
            height: a.height,
            first: SignedHalf::of(first),
            second: SignedHalf::of(second),
        })
    }

    fn signing_hash(&self, half: &SignedHalf) -> Digest {
        UnsignedHeader {
            parent: &self.parent,
            height: self.height,
            timestamp_ms: half.timestamp_ms,
            signer: self.signer,
            difficulty: half.difficulty,
            tx_root: &half.tx_root,
            evidence_root: half.evidence_root,
        }
        .digest()
    }

    /// Checks the proof on its own: a signer of the swarm, two different signed contents in
    /// canonical order (so one equivocation has one encoding), and both signatures the
    /// signer's. Says what is wrong.
    pub fn verify(&self, keys: &Keys) -> Result<(), String> {
        if self.signer >= keys.len() {
            return Err(format!(
                "signer {} is not an authorised signer",
                self.signer
            ));
        }
        if self.height == 0 {
            return Err("an equivocation at height 0 (genesis is not signed)".into());
        }
        let (a, b) = (
            self.signing_hash(&self.first),
            self.signing_hash(&self.second),
        );
        if a >= b {
            return Err("the two headers are equal or not in signing-hash order".into());
        }
        if !keys.verify(self.signer, &a, &self.first.signature)
            || !keys.verify(self.signer, &b, &self.second.signature)
        {
            return Err(format!("a signature is not signer {}'s", self.signer));
        }
        Ok(())
    }

    /// The encoded size in bytes (what it adds to a header, give or take a byte of framing).
    pub fn size_bytes(&self) -> u64 {
        rmp_serde::to_vec(self).map_or(0, |b| b.len() as u64)
    }
}

/// A set of robots, one bit each (the removed signers of a chain).
pub(crate) mod bits {
    use crate::types::RobotId;

    /// Whether `robot` is in the set.
    pub(crate) fn has(set: &[u64], robot: RobotId) -> bool {
        set.get((robot / 64) as usize)
            .is_some_and(|word| word & (1u64 << (robot % 64)) != 0)
    }

    /// Adds `robot`.
    pub(crate) fn add(set: &mut [u64], robot: RobotId) {
        if let Some(word) = set.get_mut((robot / 64) as usize) {
            *word |= 1u64 << (robot % 64);
        }
    }

    /// How many robots are in the set.
    pub(crate) fn count(set: &[u64]) -> u32 {
        set.iter().map(|w| w.count_ones()).sum()
    }

    /// The `k`-th robot (from 0, in id order) of `0..robots` not in the set, if any.
    pub(crate) fn nth_absent(set: &[u64], robots: u32, k: u32) -> Option<RobotId> {
        let mut left = k;
        for (i, word) in set.iter().enumerate() {
            let base = i as u32 * 64;
            if base >= robots {
                break;
            }
            let width = (robots - base).min(64);
            let mask = if width == 64 {
                u64::MAX
            } else {
                (1u64 << width) - 1
            };
            let absent = !word & mask;
            let n = absent.count_ones();
            if left < n {
                let mut w = absent;
                for _ in 0..left {
                    w &= w - 1;
                }
                return Some(base + w.trailing_zeros());
            }
            left -= n;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::super::{
        block, BlockHeader, ItemRef, Ledger, LedgerEvent, RejectReason, Sig, WireBlock, WireItem,
    };
    use super::{bits, Evidence};
    use crate::config::Config;
    use crate::contract::ContractParams;
    use crate::types::{RobotId, SimTime};

    /// A header on `parent` signed by `signer`, stamped `timestamp_ms`, carrying `evidence`.
    fn signed(
        ledger: &Ledger,
        parent: crate::ledger::BlockHash,
        signer: RobotId,
        timestamp_ms: u64,
        evidence: Vec<Evidence>,
    ) -> BlockHeader {
        let height = ledger.block(&parent).unwrap().block.header.height + 1;
        let mut h = BlockHeader {
            parent,
            height,
            timestamp_ms,
            signer,
            difficulty: ledger.expected_difficulty(&parent, signer),
            tx_root: block::tx_root(&[]),
            signature: Sig::ZERO,
            evidence,
        };
        h.signature = ledger.keys().sign(signer, &h.signing_hash());
        h
    }

    fn inject(ledger: &mut Ledger, at: u64, node: RobotId, header: &BlockHeader) -> u32 {
        let bytes = WireItem::Block(WireBlock {
            header: header.clone(),
            txs: vec![],
        })
        .encode();
        let applied = ledger
            .apply(SimTime(at), &LedgerEvent::Inject { node, bytes })
            .unwrap();
        applied.rejected
    }

    fn last_reason(ledger: &Ledger, node: RobotId) -> RejectReason {
        ledger
            .node(node)
            .rejections()
            .last()
            .unwrap()
            .reason
            .clone()
    }

    #[test]
    fn a_block_carrying_evidence_removes_the_sealer_from_its_chain() {
        let mut config = Config::default();
        config.world.robots = 5;
        let params = ContractParams::from_config(&config, Arc::from(vec![0i64; 8]));
        let mut ledger = Ledger::new(&config, 3, params);
        let g = ledger.genesis();
        // Robot 1 (in turn at height 1) seals A, and signs a twin B on the same parent.
        let seal = |node, parent, evidence| LedgerEvent::Seal {
            node,
            parent,
            txs: vec![],
            evidence,
        };
        ledger.apply(SimTime(10_000), &seal(1, g, vec![])).unwrap();
        let a = ledger.head(1).0;
        let twin = signed(&ledger, g, 1, 10_001, vec![]);
        assert_eq!(inject(&mut ledger, 10_001, 2, &twin), 0);
        let b = twin.hash_and_size().0;
        let send = LedgerEvent::Send {
            from: 1,
            to: 2,
            items: vec![ItemRef::Block(a)],
            lost: false,
        };
        ledger.apply(SimTime(10_002), &send).unwrap();
        ledger
            .apply(SimTime(10_003), &LedgerEvent::Deliver { message: 0 })
            .unwrap();
        let pair = (a.min(b), a.max(b));
        assert_eq!(ledger.node(2).evidence()[&(1, g)], pair);
        assert_eq!(ledger.sealable_evidence(2), vec![pair]);
        // The equivocator holds the evidence too, but never carries it against itself.
        assert!(ledger.sealable_evidence(1).is_empty());

        // Robot 2 seals with the evidence: robot 1 leaves the signer set of that chain.
        // Its head is the twin B (10_001 ms), so the earliest next block is one period later.
        let parent = ledger.head(2).0;
        ledger
            .apply(SimTime(20_001), &seal(2, parent, vec![pair]))
            .unwrap();
        let c = ledger.head(2).0;
        assert_eq!(ledger.block(&c).unwrap().block.header.evidence.len(), 1);
        assert_eq!(ledger.removed_signers(&c), vec![1]);
        assert!(ledger.removed_at(&c, 1) && !ledger.removed_at(&parent, 1));
        assert!(!ledger.may_seal_on(&c, 1));
        assert!(ledger.sealable_evidence(2).is_empty(), "already applied");
        ledger.check_block(&c).unwrap();
        ledger.check_chain(2).unwrap();
        // Four signers left, {0, 2, 3, 4}: height 3 is in turn for the fourth, robot 4 (not
        // 3 = 3 mod 5), and the window is floor(4/2) = 2 blocks.
        assert_eq!(ledger.expected_difficulty(&c, 4), 2);
        assert_eq!(ledger.expected_difficulty(&c, 3), 1);

        // A block by the removed sealer on that chain is refused, at every node alike.
        let late = signed(&ledger, c, 1, 30_001, vec![]);
        assert_eq!(inject(&mut ledger, 30_001, 2, &late), 1);
        assert_eq!(last_reason(&ledger, 2), RejectReason::RemovedSigner(1));
        assert_eq!(last_reason(&ledger, 2).kind(), "removed_signer");

        // Evidence a block may not carry: forged, or against a sealer already removed.
        let proof = Evidence::of(
            &ledger.block(&a).unwrap().block.header,
            &ledger.block(&b).unwrap().block.header,
        )
        .unwrap();
        let mut forged = proof.clone();
        forged.second.timestamp_ms += 1;
        let bad = signed(&ledger, parent, 3, 20_001, vec![forged]);
        // Sent to robot 2, which holds its parent (robot 3 never saw the twin).
        assert_eq!(inject(&mut ledger, 30_002, 2, &bad), 1);
        assert!(
            // The altered half no longer matches its signature; depending on where its new
            // signing hash falls, the order check or the signature check refuses it first.
            matches!(last_reason(&ledger, 2), RejectReason::BadEvidence(ref w)
                if w.contains("signature") || w.contains("signing-hash order")),
            "{:?}",
            last_reason(&ledger, 2)
        );
        let again = signed(&ledger, c, 4, 30_001, vec![proof]);
        assert_eq!(inject(&mut ledger, 30_003, 2, &again), 1);
        assert!(
            matches!(last_reason(&ledger, 2), RejectReason::BadEvidence(ref w) if w.contains("already removed"))
        );
        // The same two headers in either order are one proof; one header alone is none.
        let (ha, hb) = (
            &ledger.block(&a).unwrap().block.header,
            &ledger.block(&b).unwrap().block.header,
        );
        assert_eq!(Evidence::of(ha, hb), Evidence::of(hb, ha));
        assert_eq!(Evidence::of(ha, ha), None);
    }

    #[test]
    fn the_kth_absent_robot_skips_the_set() {
        let mut set = vec![0u64; 2];
        assert_eq!(bits::nth_absent(&set, 70, 0), Some(0));
        assert_eq!(bits::nth_absent(&set, 70, 69), Some(69));
        assert_eq!(bits::nth_absent(&set, 70, 70), None);
        bits::add(&mut set, 0);
        bits::add(&mut set, 3);
        bits::add(&mut set, 64);
        assert_eq!(bits::count(&set), 3);
        assert_eq!(bits::nth_absent(&set, 70, 0), Some(1));
        assert_eq!(bits::nth_absent(&set, 70, 2), Some(4));
        assert_eq!(bits::nth_absent(&set, 70, 62), Some(65));
        assert_eq!(bits::nth_absent(&set, 70, 66), Some(69));
        assert_eq!(bits::nth_absent(&set, 70, 67), None);
        assert!(bits::has(&set, 64) && !bits::has(&set, 65) && !bits::has(&set, 999));
    }
}

//! Blocks: a header (parent hash, height, timestamp, signer, difficulty, transaction root,
//! signature) and the ordered list of its transactions.
//!
//! A block's id ([`BlockHash`]) is blake3 of its full encoded header, signature included (so a
//! forgery is a different item); the signer signs [`BlockHeader::signing_hash`], blake3 of the
//! encoded header without the signature. The transaction root is blake3 over the concatenated
//! transaction ids, so the header commits to the body.

use serde::{Deserialize, Serialize};

use super::keys::Sig;
use super::tx::{Tx, TxHash};
use crate::types::{Digest, RobotId};

/// The id of a block: blake3 of its encoded header.
pub type BlockHash = Digest;

/// Most transactions one block may hold; a block with more is malformed. The swarm produces
/// at most a few transactions per block period, so this bound is never reached by honest nodes.
pub const MAX_BLOCK_TXS: usize = 1024;

/// The signer field of the genesis block, which nobody signs.
pub const GENESIS_SIGNER: RobotId = RobotId::MAX;

/// A block header.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BlockHeader {
    /// The parent's id (for genesis: the digest of the contract parameters, so that the genesis
    /// id commits to them).
    pub parent: BlockHash,
    /// Distance from genesis (genesis is 0).
    pub height: u64,
    /// Simulated time of sealing, in milliseconds.
    pub timestamp_ms: u64,
    /// The sealing robot ([`GENESIS_SIGNER`] for genesis).
    pub signer: RobotId,
    /// Clique difficulty: 2 in turn, 1 out of turn (0 for genesis).
    pub difficulty: u64,
    /// blake3 over the concatenated ids of the block's transactions.
    pub tx_root: Digest,
    /// The signer's ed25519 signature of [`BlockHeader::signing_hash`].
    pub signature: Sig,
    /// Equivocation proofs against other sealers (see `ledger/evidence.rs`): the block removes
    /// them from its chain's signer set. Absent from the encoding when empty, so a block
    /// without evidence encodes (and hashes) as before the field existed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub evidence: Vec<Evidence>,
}

/// What a signer signs: the header without its signature, the evidence by its digest (so that
/// an equivocation's proof need not nest the evidence its headers carried).
#[derive(Serialize)]
pub(super) struct UnsignedHeader<'a> {
    pub(super) parent: &'a BlockHash,
    pub(super) height: u64,
    pub(super) timestamp_ms: u64,
    pub(super) signer: RobotId,
    pub(super) difficulty: u64,
    pub(super) tx_root: &'a Digest,
    /// Absent when the header carries no evidence: the signing hash of such a header is the
    /// one it had before evidence existed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) evidence_root: Option<Digest>,
}

impl UnsignedHeader<'_> {
    /// blake3 of the encoding.
    pub(super) fn digest(&self) -> Digest {
        Digest::of(&rmp_serde::to_vec(self).expect("a header always encodes"))
    }
}

impl BlockHeader {
    /// The digest the signer signs.
    pub fn signing_hash(&self) -> Digest {
        UnsignedHeader {
            parent: &self.parent,
            height: self.height,
            timestamp_ms: self.timestamp_ms,
            signer: self.signer,
            difficulty: self.difficulty,
            tx_root: &self.tx_root,
            evidence_root: evidence_root(&self.evidence),
        }
        .digest()
    }

    /// The block id and the encoded header size in bytes.
    pub fn hash_and_size(&self) -> (BlockHash, u32) {
        let bytes = rmp_serde::to_vec(self).expect("a header always encodes");
        (Digest::of(&bytes), bytes.len() as u32)
    }
}

/// The transaction root of an ordered list of transaction ids.
pub fn tx_root(txs: &[TxHash]) -> Digest {
    let mut hasher = blake3::Hasher::new();
    for h in txs {
        hasher.update(&h.0);
    }
    hasher.finalize().into()
}

/// A block as stored: its header and the ids of its transactions, in execution order. The
/// transaction bodies live once in the ledger's shared storage.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Block {
    /// The header.
    pub header: BlockHeader,
    /// Transaction ids, in execution order.
    pub txs: Vec<TxHash>,
}

/// A block with its transaction bodies: what travels between nodes when the content is not in
/// the shared storage yet (an injected, possibly forged block).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct WireBlock {
    /// The header.
    pub header: BlockHeader,
    /// The transactions, in execution order.
    pub txs: Vec<Tx>,
}

/// An item travelling between nodes in full (see [`super::LedgerEvent::Inject`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum WireItem {
    /// A transaction.
    Tx(Tx),
    /// A block with its transactions.
    Block(WireBlock),
}

impl WireItem {
    /// The canonical encoding.
    pub fn encode(&self) -> Vec<u8> {
        rmp_serde::to_vec(self).expect("a wire item always encodes")
    }
}

// The data of an equivocation proof, which headers carry; what it proves and how it is
// checked is in `evidence.rs`.

/// What distinguishes one of the two headers of an equivocation: everything the signer signed
/// but the parent, height and signer, which the two share, and the signature.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignedHalf {
    /// The header's timestamp, ms.
    pub timestamp_ms: u64,
    /// Its difficulty.
    pub difficulty: u64,
    /// Its transaction root.
    pub tx_root: Digest,
    /// The digest of the evidence it carried, if any (see [`evidence_root`]).
    pub evidence_root: Option<Digest>,
    /// The signer's signature of the header.
    pub signature: Sig,
}

/// Proof that `signer` signed two different headers on `parent`: enough to recompute both
/// signing hashes and check both signatures.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Evidence {
    /// The equivocating sealer.
    pub signer: RobotId,
    /// The block both headers name as parent.
    pub parent: BlockHash,
    /// Their height.
    pub height: u64,
    /// The header with the lower signing hash.
    pub first: SignedHalf,
    /// The other.
    pub second: SignedHalf,
}

/// The digest a header's signature commits to for the evidence it carries: blake3 of the
/// encoded list, or None for none (then the signing hash is the one of a header without
/// evidence, byte for byte).
pub fn evidence_root(evidence: &[Evidence]) -> Option<Digest> {
    (!evidence.is_empty())
        .then(|| Digest::of(&rmp_serde::to_vec(evidence).expect("evidence always encodes")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_id_covers_the_signature_and_the_root_covers_the_order() {
        let h = BlockHeader {
            parent: Digest::of(b"p"),
            height: 3,
            timestamp_ms: 30_000,
            signer: 3,
            difficulty: 2,
            tx_root: tx_root(&[]),
            signature: Sig::ZERO,
            evidence: Vec::new(),
        };
        let mut signed = h.clone();
        signed.signature = Sig([7; 64]);
        assert_ne!(h.hash_and_size().0, signed.hash_and_size().0);
        assert_eq!(h.signing_hash(), signed.signing_hash());
        let (a, b) = (Digest::of(b"a"), Digest::of(b"b"));
        assert_ne!(tx_root(&[a, b]), tx_root(&[b, a]));
        assert_ne!(tx_root(&[a]), tx_root(&[]));
    }
}

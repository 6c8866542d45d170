//! Transactions: sender, nonce, value, call, signature.
//!
//! A transaction's *id* ([`TxHash`]) is the blake3 hash of its full signed encoding
//! (rmp-serde), as Ethereum's transaction hash covers the signature: a forgery that copies an
//! honest body with another signature is a different item and can never shadow the honest one
//! in content-addressed storage. The signature covers [`Tx::signing_hash`], the blake3 hash of
//! the encoding of the unsigned body *and of the chain identity* (the genesis block's id, held
//! by [`Keys::chain`]): as with EIP-155, the identity is signed but not carried, so a
//! transaction signed for another run (another genesis) fails the signature check here, and
//! the encoded size (the paper's bytes per submission) does not change.

use serde::{Deserialize, Serialize};

use super::keys::{Keys, Sig};
use crate::contract::gas_limit::TxGas;
use crate::contract::{Call, ContractParams, ContractState, Outcome};
use crate::types::{Digest, RobotId};

/// The id of a transaction: blake3 of its signed encoding.
pub type TxHash = Digest;

/// Largest encoded transaction a node accepts, in bytes: a 2848-weight submission encodes to
/// about 14 KB; anything beyond this bound is malformed.
pub const MAX_TX_BYTES: usize = 1 << 20;

/// A signed transaction.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Tx {
    /// The sending account (a robot id).
    pub sender: RobotId,
    /// The sender's transaction counter: its n-th transaction has nonce n (0-based).
    pub nonce: u64,
    /// Units transferred to the contract with the call (the stake).
    pub value_units: u64,
    /// The contract call.
    pub call: Call,
    /// The sender's ed25519 signature of [`Tx::signing_hash`].
    pub signature: Sig,
    /// The gas estimate and limit its sender's node set (`contract.gas_limit = "estimate"`,
    /// [`crate::contract::gas_limit`]); signed, as an Ethereum transaction's gas limit is.
    /// Absent otherwise, and then left out of the encoding and the signed body, so the
    /// transactions of runs without it keep their hashes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gas: Option<TxGas>,
}

/// The signed part of a transaction, borrowed.
#[derive(Serialize)]
struct UnsignedTx<'a> {
    chain: &'a Digest,
    sender: RobotId,
    nonce: u64,
    value_units: u64,
    call: &'a Call,
    #[serde(skip_serializing_if = "Option::is_none")]
    gas: Option<&'a TxGas>,
}

impl Tx {
    /// Executes this transaction's call on `state` under `params`: its sender, stake and
    /// call, with its own gas limit when it carries one
    /// ([`ContractState::execute_with_gas`]). Every place that applies a stored transaction
    /// to a contract state (validation, audit, a node's pending block) goes through here.
    pub fn execute_on(&self, state: &mut ContractState, params: &ContractParams) -> Outcome {
        state.execute_with_gas(
            params,
            self.sender,
            self.value_units,
            &self.call,
            self.gas.map(|g| g.limit),
        )
    }

    /// A transaction signed by `sender`'s key.
    pub fn signed(keys: &Keys, sender: RobotId, nonce: u64, value_units: u64, call: Call) -> Tx {
        Tx::signed_with_gas(keys, sender, nonce, value_units, call, None)
    }

    /// A transaction signed by `sender`'s key, carrying its own gas limit when `gas` is given.
    pub fn signed_with_gas(
        keys: &Keys,
        sender: RobotId,
        nonce: u64,
        value_units: u64,
        call: Call,
        gas: Option<TxGas>,
    ) -> Tx {
        let mut tx = Tx {
            sender,
            nonce,
            value_units,
            call,
            signature: Sig::ZERO,
            gas,
        };
        tx.signature = keys.sign(sender, &tx.signing_hash(&keys.chain()));
        tx
    }

    /// The digest the sender signs: blake3 of the encoded unsigned body on chain `chain`.
    pub fn signing_hash(&self, chain: &Digest) -> Digest {
        let body = UnsignedTx {
            chain,
            sender: self.sender,
            nonce: self.nonce,
            value_units: self.value_units,
            call: &self.call,
            gas: self.gas.as_ref(),
        };
        Digest::of(&rmp_serde::to_vec(&body).expect("a transaction body always encodes"))
    }

    /// The canonical encoding (what travels and what the chain stores).
    pub fn encode(&self) -> Vec<u8> {
        rmp_serde::to_vec(self).expect("a transaction always encodes")
    }

    /// Decodes a transaction; the error says what is wrong with the bytes.
    pub fn decode(bytes: &[u8]) -> Result<Tx, String> {
        rmp_serde::from_slice(bytes).map_err(|e| format!("undecodable transaction: {e}"))
    }

    /// The id and encoded size of this transaction.
    pub fn hash_and_size(&self) -> (TxHash, u32) {
        let bytes = self.encode();
        (Digest::of(&bytes), bytes.len() as u32)
    }

    /// Whether the signature is the sender's for the keys' chain (false for an unknown
    /// sender or a transaction signed for another chain).
    pub fn signature_ok(&self, keys: &Keys) -> bool {
        keys.verify(
            self.sender,
            &self.signing_hash(&keys.chain()),
            &self.signature,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashes_cover_the_signature_and_signatures_cover_the_body() {
        let keys = Keys::new(1, 3);
        let tx = Tx::signed(
            &keys,
            1,
            0,
            5,
            Call::Transfer {
                to: 2,
                amount_units: 7,
            },
        );
        assert!(tx.signature_ok(&keys));
        let mut forged = tx.clone();
        forged.signature = Sig::ZERO;
        assert!(!forged.signature_ok(&keys));
        assert_ne!(forged.hash_and_size().0, tx.hash_and_size().0);
        let mut altered = tx.clone();
        altered.value_units = 6;
        assert!(!altered.signature_ok(&keys));
        let mut impostor = tx.clone();
        impostor.sender = 0;
        assert!(!impostor.signature_ok(&keys));
        impostor.sender = 99;
        assert!(!impostor.signature_ok(&keys));
        let other_chain = keys.clone().for_chain(Digest::of(b"another run"));
        assert!(
            !tx.signature_ok(&other_chain),
            "a replay into another chain"
        );
        let there = Tx::signed(&other_chain, 1, 0, 5, tx.call.clone());
        assert!(there.signature_ok(&other_chain) && !there.signature_ok(&keys));
        assert_eq!(
            there.encode().len(),
            tx.encode().len(),
            "the identity is not carried"
        );
        assert_eq!(Tx::decode(&tx.encode()).unwrap(), tx);
        assert!(Tx::decode(&tx.encode()[..10]).is_err());
    }
}

//! Signing keys: one ed25519 key pair per robot, derived from the run's seed.
//!
//! Every robot is an authorised Clique signer, so the verifying keys of all robots are the
//! signer set. Keys are a pure function of (seed, robot): `rng::derive_bytes(seed,
//! Purpose::Keys, robot)` is the 32-byte secret.

use ed25519_dalek::{Signature, Signer, SigningKey, Verifier, VerifyingKey};

use crate::rng::{self, Purpose};
use crate::types::{Digest, RobotId};

/// An ed25519 signature, serialised as 64 bytes.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Sig(pub [u8; 64]);

impl Sig {
    /// The all-zero signature (genesis, and a handy forgery in tests).
    pub const ZERO: Sig = Sig([0u8; 64]);
}

impl std::fmt::Debug for Sig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Sig({})", Digest::of(&self.0).short())
    }
}

impl serde::Serialize for Sig {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(&self.0)
    }
}

impl<'de> serde::Deserialize<'de> for Sig {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Sig, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Sig;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("64 bytes")
            }
            fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Sig, E> {
                <[u8; 64]>::try_from(v)
                    .map(Sig)
                    .map_err(|_| E::invalid_length(v.len(), &self))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Sig, A::Error> {
                let mut out = [0u8; 64];
                for (i, b) in out.iter_mut().enumerate() {
                    *b = seq
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Sig(out))
            }
        }
        d.deserialize_bytes(V)
    }
}

/// The key pairs of every robot of a run.
#[derive(Clone, Debug)]
pub struct Keys {
    signing: Vec<SigningKey>,
    verifying: Vec<VerifyingKey>,
    /// The chain identity every transaction signature commits to (the genesis block's id;
    /// all zero bytes for keys not bound to a chain).
    chain: Digest,
}

impl Keys {
    /// The keys of robots `0..robots` in the run seeded with `seed`.
    pub fn new(seed: u64, robots: u32) -> Keys {
        let signing: Vec<SigningKey> = (0..robots)
            .map(|r| SigningKey::from_bytes(&rng::derive_bytes(seed, Purpose::Keys, r)))
            .collect();
        let verifying = signing.iter().map(SigningKey::verifying_key).collect();
        Keys {
            signing,
            verifying,
            chain: Digest::default(),
        }
    }

    /// The same keys bound to the chain `chain` (its genesis id): transactions signed with
    /// them commit to it, and only they verify (EIP-155's replay protection).
    pub fn for_chain(mut self, chain: Digest) -> Keys {
        self.chain = chain;
        self
    }

    /// The chain identity transaction signatures commit to.
    pub fn chain(&self) -> Digest {
        self.chain
    }

    /// Number of robots (authorised signers).
    pub fn len(&self) -> u32 {
        self.signing.len() as u32
    }

    /// True when there are no robots.
    pub fn is_empty(&self) -> bool {
        self.signing.is_empty()
    }

    /// `robot` signs `message` (a 32-byte digest). ed25519 signing is deterministic.
    pub fn sign(&self, robot: RobotId, message: &Digest) -> Sig {
        let key = &self.signing[robot as usize];
        Sig(key.sign(&message.0).to_bytes())
    }

    /// Whether `sig` is `robot`'s signature of `message`; false for an unknown robot.
    pub fn verify(&self, robot: RobotId, message: &Digest, sig: &Sig) -> bool {
        let Some(key) = self.verifying.get(robot as usize) else {
            return false;
        };
        key.verify(&message.0, &Signature::from_bytes(&sig.0))
            .is_ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_deterministic_and_signatures_verify_only_for_their_signer() {
        let a = Keys::new(3, 4);
        let b = Keys::new(3, 4);
        let m = Digest::of(b"hello");
        let s = a.sign(2, &m);
        assert_eq!(s, b.sign(2, &m));
        assert!(b.verify(2, &m, &s));
        assert!(!b.verify(1, &m, &s));
        assert!(!b.verify(9, &m, &s));
        assert!(!b.verify(2, &Digest::of(b"other"), &s));
        assert!(!b.verify(2, &m, &Sig::ZERO));
        assert_ne!(Keys::new(4, 4).sign(2, &m), s);
        let bytes = rmp_serde::to_vec(&s).unwrap();
        assert_eq!(bytes.len(), 66);
        assert_eq!(rmp_serde::from_slice::<Sig>(&bytes).unwrap(), s);
        assert!(rmp_serde::from_slice::<Sig>(&bytes[..40]).is_err());
    }
}

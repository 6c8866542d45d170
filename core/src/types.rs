//! Small types shared by every module: robot ids, simulated time, digests, and how a message
//! writes a number.

use std::fmt;

use serde::{Deserialize, Serialize};

/// A robot's index in the swarm, 0-based; also its node's signer index.
pub type RobotId = u32;

/// Simulated time in integer milliseconds since the start of the run. Nothing in swarmfl reads
/// the wall clock; all time is this.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct SimTime(pub u64);

impl SimTime {
    /// The time in seconds.
    pub fn secs(self) -> f64 {
        self.0 as f64 / 1000.0
    }

    /// The time `s` seconds after the start, rounded to the millisecond.
    pub fn from_secs(s: f64) -> SimTime {
        debug_assert!(s.is_finite() && s >= 0.0, "SimTime::from_secs({s})");
        SimTime((s * 1000.0).round() as u64)
    }
}

impl fmt::Display for SimTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:03} s", self.0 / 1000, self.0 % 1000)
    }
}

/// A 32-byte blake3 digest, serialised as a byte string and shown as hex.
#[derive(Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Digest(pub [u8; 32]);

impl Digest {
    /// The digest of `bytes`.
    pub fn of(bytes: &[u8]) -> Digest {
        Digest(*blake3::hash(bytes).as_bytes())
    }

    /// Lower-case hex, 64 characters.
    pub fn to_hex(&self) -> String {
        blake3::Hash::from(self.0).to_hex().to_string()
    }

    /// Parses 64 hex characters.
    pub fn from_hex(s: &str) -> Option<Digest> {
        blake3::Hash::from_hex(s)
            .ok()
            .map(|h| Digest(*h.as_bytes()))
    }

    /// The first 8 bytes as hex, for humans.
    pub fn short(&self) -> String {
        self.to_hex()[..16].to_string()
    }
}

impl From<blake3::Hash> for Digest {
    fn from(h: blake3::Hash) -> Digest {
        Digest(*h.as_bytes())
    }
}

impl fmt::Debug for Digest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Digest({})", self.short())
    }
}

impl fmt::Display for Digest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_hex())
    }
}

impl Serialize for Digest {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(&self.0)
    }
}

impl<'de> Deserialize<'de> for Digest {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Digest, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Digest;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("32 bytes")
            }
            fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Digest, E> {
                <[u8; 32]>::try_from(v)
                    .map(Digest)
                    .map_err(|_| E::invalid_length(v.len(), &self))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<Digest, A::Error> {
                let mut out = [0u8; 32];
                for (i, b) in out.iter_mut().enumerate() {
                    *b = seq
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Digest(out))
            }
        }
        d.deserialize_bytes(V)
    }
}

/// A number as a message shows it: compactly in scientific notation when it is huge or tiny
/// (`1e300`, not 301 digits), as Rust prints it otherwise (`0.5`, `10000`).
pub fn show_f64(value: f64) -> String {
    let a = value.abs();
    if value.is_finite() && value != 0.0 && !(1e-6..1e16).contains(&a) {
        format!("{value:e}")
    } else {
        value.to_string()
    }
}

#[cfg(test)]
mod show_tests {
    use super::*;

    #[test]
    fn huge_and_tiny_numbers_are_shown_compactly() {
        for (v, shown) in [
            (1e300, "1e300"),
            (-2.5e20, "-2.5e20"),
            (1.5e-9, "1.5e-9"),
            (0.5, "0.5"),
            (10_000_000.0, "10000000"),
            (0.0, "0"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(show_f64(v), shown);
        }
    }
}

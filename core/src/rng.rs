//! Seeded randomness in independent streams.
//!
//! Every random draw of a run comes from a [`Rng`] obtained with [`stream`] for a
//! ([`Purpose`], robot) pair. The stream's 256-bit state is derived from the run's seed with
//! blake3, so streams never share state: adding a draw in one place leaves every other stream
//! unchanged. Floating-point draws are built from integer bits and `libm` only, so they are the
//! same on every platform.

use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

/// What a stream of random numbers is used for. The discriminant is part of the derivation:
/// never renumber a variant, only append.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[repr(u32)]
pub enum Purpose {
    /// Obstacle placement (one stream for the arena, robot id 0).
    Obstacles = 1,
    /// Initial robot poses (one stream, robot id 0).
    Placement = 2,
    /// A robot's controller (random-walk turns).
    Controller = 3,
    /// Range-and-bearing noise and packet drop as measured by a robot.
    RangeAndBearing = 4,
    /// The noise-free ground-truth observer (held-out set), robot id 0.
    Heldout = 5,
    /// Initial model weights (genesis), robot id 0.
    ModelInit = 6,
    /// A robot's dropout masks during local training.
    Dropout = 7,
    /// A robot's training-phase offset.
    Schedule = 8,
    /// A Byzantine robot's forged weights.
    Byzantine = 9,
    /// A node's out-of-turn sealing delays.
    Sealing = 10,
    /// Gossip packet loss on links from a robot.
    Network = 11,
    /// A node's signing key (the key seed, not a stream of draws).
    Keys = 12,
    /// Which robots are Byzantine (one stream, robot id 0).
    ByzantineSelection = 13,
    /// The chaos campaign's draws of a run's configuration and faults (robot id 0).
    Faults = 14,
    /// A Byzantine robot's ledger misbehaviour (spam contents, targets).
    LedgerAttack = 15,
    /// Packet loss on the virtual-stigmergy gossip links from a robot (`learn.aggregation =
    /// "gossip"`).
    Stigmergy = 16,
    /// Flow-FL's foraging rule (`world/foraging_flowfl.rs`): a forager's rest and exploration
    /// draws (its robot id), and the food items' placements (robot id `u32::MAX`).
    Foraging = 17,
    /// A robot's home range (`world.home_range`, `world/home_range.rs`): its preference vector
    /// over the regions (the stream of its robot id) and each goal period's pick (one
    /// substream per period).
    HomeRange = 18,
    /// The authors' timing (`learn.timing = "authors"`, `sim/timing/authors.rs`): a robot's
    /// jitter around the swarm's shared timer in each cycle (one substream per cycle).
    Timing = 19,
}

/// A deterministic random number generator (PCG 128/64, "Pcg64") with portable float draws.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rng {
    inner: Pcg64,
}

/// The stream of `purpose` for `robot` in the run seeded with `seed`.
pub fn stream(seed: u64, purpose: Purpose, robot: u32) -> Rng {
    Rng {
        inner: Pcg64::from_seed(derive_bytes(seed, purpose, robot)),
    }
}

/// The `index`-th independent stream of `purpose` for `robot` (e.g. one per local training), so
/// that an event's randomness depends only on (seed, purpose, robot, index) and not on how many
/// draws earlier events made.
pub fn substream(seed: u64, purpose: Purpose, robot: u32, index: u64) -> Rng {
    let mut material = [0u8; 24];
    material[..8].copy_from_slice(&seed.to_le_bytes());
    material[8..12].copy_from_slice(&(purpose as u32).to_le_bytes());
    material[12..16].copy_from_slice(&robot.to_le_bytes());
    material[16..].copy_from_slice(&index.to_le_bytes());
    Rng {
        inner: Pcg64::from_seed(blake3::derive_key(
            "swarmfl 2026-11 rng substream v1",
            &material,
        )),
    }
}

/// 32 bytes derived from (seed, purpose, robot) with blake3's key derivation; used for stream
/// seeds and for signing keys.
pub fn derive_bytes(seed: u64, purpose: Purpose, robot: u32) -> [u8; 32] {
    let mut material = [0u8; 16];
    material[..8].copy_from_slice(&seed.to_le_bytes());
    material[8..12].copy_from_slice(&(purpose as u32).to_le_bytes());
    material[12..].copy_from_slice(&robot.to_le_bytes());
    blake3::derive_key("swarmfl 2026-11 rng stream v1", &material)
}

impl Rng {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.inner.next_u64()
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        (self.inner.next_u64() >> 32) as u32
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [0, 1) as f32 with 24 random bits.
    pub fn uniform_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Uniform integer in [0, n), without modulo bias. `n` must be positive.
    pub fn below(&mut self, n: u64) -> u64 {
        assert!(n > 0, "Rng::below needs n > 0");
        let zone = u64::MAX - (u64::MAX - n + 1) % n;
        loop {
            let x = self.next_u64();
            if x <= zone {
                return x % n;
            }
        }
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && self.uniform() < p
    }

    /// A standard normal draw (Box-Muller with `libm`, one draw per call: no cached pair, so
    /// that the stream position depends only on the number of calls).
    pub fn normal(&mut self) -> f64 {
        // u1 in (0, 1] so that ln is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(2.0 * core::f64::consts::PI * u2)
    }

    /// The natural logarithm of a Gamma(`shape`, 1) draw, `shape` > 0 and finite: Marsaglia
    /// and Tsang's squeeze (2000) on [`Rng::normal`] and [`Rng::uniform`] draws, with only
    /// IEEE basic operations and `libm::{sqrt, log}` (no fused multiply-add), so it is the
    /// same on every platform. For `shape < 1` it draws Gamma(`shape + 1`) and multiplies by
    /// `u^(1/shape)`, in logarithms so that a small shape (a Dirichlet's 0.1) never
    /// underflows to 0.
    pub fn ln_gamma_draw(&mut self, shape: f64) -> f64 {
        assert!(
            shape > 0.0 && shape.is_finite(),
            "a validated Gamma shape is positive and finite"
        );
        if shape < 1.0 {
            let boost = 1.0 - self.uniform();
            return self.ln_gamma_draw(shape + 1.0) + libm::log(boost) / shape;
        }
        let d = shape - 1.0 / 3.0;
        let c = 1.0 / libm::sqrt(9.0 * d);
        loop {
            let x = self.normal();
            let t = 1.0 + c * x;
            if t <= 0.0 {
                continue;
            }
            let v = t * t * t;
            let u = 1.0 - self.uniform();
            let x2 = x * x;
            if u < 1.0 - 0.0331 * x2 * x2 || libm::log(u) < 0.5 * x2 + d * (1.0 - v + libm::log(v))
            {
                return libm::log(d) + libm::log(v);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_draws_have_the_shapes_mean_and_variance() {
        // Gamma(a, 1) has mean a and variance a: 20 000 draws put the sample mean within
        // about 4 standard errors.
        for shape in [0.1, 0.5, 1.0, 3.0, 10.0] {
            let mut r = stream(3, Purpose::HomeRange, 0);
            let n = 20_000;
            let draws: Vec<f64> = (0..n).map(|_| libm::exp(r.ln_gamma_draw(shape))).collect();
            let mean = draws.iter().sum::<f64>() / f64::from(n);
            let var = draws.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / f64::from(n);
            let se = (shape / f64::from(n)).sqrt();
            assert!(
                (mean - shape).abs() < 4.0 * se,
                "shape {shape}: mean {mean}"
            );
            assert!(
                (var - shape).abs() < 0.15 * shape,
                "shape {shape}: variance {var}"
            );
        }
    }

    fn draws(rng: &mut Rng, n: usize) -> Vec<u64> {
        (0..n).map(|_| rng.next_u64()).collect()
    }

    #[test]
    fn extra_draws_in_one_stream_leave_every_other_stream_unchanged() {
        let seed = 7;
        let keys = [
            (Purpose::Controller, 0),
            (Purpose::Controller, 1),
            (Purpose::Dropout, 0),
            (Purpose::RangeAndBearing, 3),
        ];
        // Run A: interleave draws; run B: the same, plus 1000 extra draws in the first stream.
        let mut a: Vec<Rng> = keys.iter().map(|&(p, r)| stream(seed, p, r)).collect();
        let mut b: Vec<Rng> = keys.iter().map(|&(p, r)| stream(seed, p, r)).collect();
        let _ = draws(&mut b[0], 1000);
        for (i, (ra, rb)) in a.iter_mut().zip(b.iter_mut()).enumerate().skip(1) {
            assert_eq!(draws(ra, 100), draws(rb, 100), "stream {i} shifted");
        }
    }

    #[test]
    fn substreams_are_independent_of_each_other_and_of_streams() {
        let a = draws(&mut substream(1, Purpose::Dropout, 2, 0), 4);
        assert_eq!(a, draws(&mut substream(1, Purpose::Dropout, 2, 0), 4));
        assert_ne!(a, draws(&mut substream(1, Purpose::Dropout, 2, 1), 4));
        assert_ne!(a, draws(&mut substream(1, Purpose::Dropout, 3, 0), 4));
        assert_ne!(a, draws(&mut stream(1, Purpose::Dropout, 2), 4));
    }

    #[test]
    fn streams_differ_by_seed_purpose_and_robot() {
        let base = draws(&mut stream(1, Purpose::Controller, 0), 4);
        assert_ne!(base, draws(&mut stream(2, Purpose::Controller, 0), 4));
        assert_ne!(base, draws(&mut stream(1, Purpose::Dropout, 0), 4));
        assert_ne!(base, draws(&mut stream(1, Purpose::Controller, 1), 4));
        assert_eq!(base, draws(&mut stream(1, Purpose::Controller, 0), 4));
    }

    #[test]
    fn draws_are_pinned() {
        // Pins the derivation: a change here changes every run's log.
        let mut r = stream(42, Purpose::Controller, 3);
        let u = r.uniform();
        assert!((0.0..1.0).contains(&u));
        let n: f64 = (0..10_000).map(|_| r.normal()).sum::<f64>() / 10_000.0;
        assert!(n.abs() < 0.05, "normal mean {n}");
        assert!((0..1000).all(|_| r.below(7) < 7));
        let mut again = stream(42, Purpose::Controller, 3);
        assert_eq!(again.uniform().to_bits(), u.to_bits());
    }

    #[test]
    fn rng_state_round_trips_through_serde() {
        let mut r = stream(5, Purpose::Network, 2);
        r.next_u64();
        let bytes = rmp_serde::to_vec(&r).unwrap();
        let mut back: Rng = rmp_serde::from_slice(&bytes).unwrap();
        assert_eq!(back.next_u64(), r.next_u64());
    }
}

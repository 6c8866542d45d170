//! `extreme-value`, the extreme-value attack (ByzFL's `Inf`, which sends `+inf` in every coordinate):
//! every weight is the largest value the contract accepts, `+(2^47 - 1) / scale` rounded down
//! to the nearest `f32` that still converts inside int48 ([`extreme`]). A literal infinity would
//! not reach any rule: the driver cannot put it on chain and the contract refuses weights
//! outside int48 as malformed. At the edge of int48 it does reach the rule: it is the worst
//! case for every mean (fedavg, and paper's threshold aside), and it checks that no rule's
//! integer arithmetic overflows on the largest legal inputs.
//!
//! Information: none. Parameters: `byzantine.claimed_samples`.

use super::{submit, Action, Attack, View};
use crate::learn;
use crate::rng::Rng;

/// The `extreme-value` agent (not named `inf`: a bare `inf` is a TOML float, so
/// `--set byzantine.kind=inf` would not read as a name).
pub struct ExtremeValue;

/// The largest positive `f32` whose fixed-point value at `scale` (> 0) lies inside int48.
pub fn extreme(scale: u64) -> f32 {
    let limit = learn::fixed::FIXED_LIMIT;
    let mut v = (limit / scale as f64) as f32;
    // The quotient's rounding to f32 is at most one unit of the last place above the limit,
    // and each step down moves one unit: a few steps at most.
    for _ in 0..64 {
        if (f64::from(v) * scale as f64).round() < limit {
            return v;
        }
        v = f32::from_bits(v.to_bits() - 1);
    }
    unreachable!("an f32 below 2^47 / {scale} lies within 64 units of the last place");
}

impl Attack for ExtremeValue {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        submit(
            view,
            vec![extreme(view.weight_scale); view.chain.weights.len()],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_largest_weight_the_chain_accepts() {
        for scale in [1u64, 1000, 1_000_000_000, 1_000_000_000_000] {
            let v = extreme(scale);
            let fixed = learn::to_fixed(&[v], scale).expect("inside int48");
            assert!(fixed[0] > 0 && fixed[0].unsigned_abs() < 1 << 47);
            let next = f32::from_bits(v.to_bits() + 1);
            assert!(
                learn::to_fixed(&[next], scale).is_err(),
                "the next f32 is outside"
            );
        }
        // Scale 1e9: 2^47 / 1e9 = 140737.488..; the f32 grid there is 1/64: 140737.484375.
        assert_eq!(f64::from(extreme(1_000_000_000)), 140_737.484_375_f64);
    }
}

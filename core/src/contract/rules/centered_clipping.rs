//! `centered-clipping` (Karimireddy et al., 2021): clip every model's difference from a
//! center to a radius, average, move the center, [`ITERATIONS`] times.
//!
//! The center starts at the shared model `v = w(t)` the round was opened on. The radius is
//! `tau` = the lower median (`sorted[(q - 1) / 2]`) of the models' Euclidean distances to
//! `w(t)`, each `floor(sqrt(.))` of the exact squared distance: half the models are never
//! clipped, so honest progress passes while a far model contributes at most `tau`. One
//! iteration: for each model `x = w_k - v`, `n = floor(sqrt(|x|^2))`; if `n <= tau` the
//! contribution is `x`, else `x_i * tau / n` rounded half away from zero; then
//! `v_i += sum_k c_k,i / q` rounded half away from zero. `tau` stays fixed across the
//! iterations. Sample counts are ignored; defined for `q >= 2f + 1`.
//!
//! Used: the `q - f` submissions nearest the result in L1 (nearest first, ties to the earlier
//! submission).

use super::{isqrt, nearest, squared_distance, Aggregate, Input};
use crate::contract::payout::div_round_half_away;

/// Clipping iterations per aggregation.
pub const ITERATIONS: usize = 3;

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct CenteredClipping;

impl super::AggregationRule for CenteredClipping {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.current, round.inputs, round.f)
    }
}

/// The center after [`ITERATIONS`] clipped averaging steps from `current`.
pub fn aggregate(current: &[i64], inputs: &[Input], f: usize) -> Aggregate {
    let q = inputs.len();
    let mut norms: Vec<u128> = inputs
        .iter()
        .map(|s| isqrt(squared_distance(s.weights, current)))
        .collect();
    norms.sort_unstable();
    let tau = i128::try_from(norms[(q - 1) / 2]).expect("a norm below 2^57");
    let mut v = current.to_vec();
    let mut sum = vec![0i128; v.len()];
    for _ in 0..ITERATIONS {
        sum.iter_mut().for_each(|s| *s = 0);
        for s in inputs {
            let n = i128::try_from(isqrt(squared_distance(s.weights, &v))).expect("below 2^57");
            for ((acc, &w), &c) in sum.iter_mut().zip(s.weights).zip(&v) {
                let x = i128::from(w) - i128::from(c);
                *acc += if n <= tau {
                    x
                } else {
                    div_round_half_away(x * tau, n)
                };
            }
        }
        for (c, &s) in v.iter_mut().zip(&sum) {
            let step = div_round_half_away(s, q as i128);
            *c = i64::try_from(i128::from(*c) + step).expect("a clipped mean between inputs");
        }
    }
    let used = nearest(inputs, &v, q.saturating_sub(f).max(1));
    Aggregate { weights: v, used }
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn clips_far_models_to_the_median_radius() {
        // Distances to 0: 1, 2, 3, 100, 1 -> sorted 1, 1, 2, 3, 100: tau = 2.
        // v = 0: contributions 1, 2, 2 (3 clipped), 2 (100 clipped), -1: 6 / 5 -> 1.
        // v = 1: 0, 1, 2, 2 (99 clipped), -2: 3 / 5 -> 1, v = 2.
        // v = 2: -1, 0, 1, 2 (98 clipped), -2 (-3 clipped): 0, v stays 2.
        let a = aggregate(
            &[0],
            &inputs_of(&[(&[1], 1), (&[2], 1), (&[3], 1), (&[100], 1), (&[-1], 1)]),
            1,
        );
        assert_eq!(a.weights, vec![2]);
        assert_eq!(a.used, vec![1, 0, 2, 4]);
    }
}

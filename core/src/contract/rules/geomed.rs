//! `geomed`: the geometric median (the point minimising the sum of Euclidean distances to the
//! models; Pillutla et al., 2022, RFA) by [`STEPS`] fixed-point Weiszfeld steps.
//!
//! Start: `z` = the unweighted mean, rounded half away from zero. One step: for each model
//! `d_k = max(floor(sqrt(sum_i (w_k,i - z_i)^2)), 1)` (the 1-unit floor keeps a model sitting
//! on `z` finite), `b_k = floor(2^64 / d_k)`, and `z_i = sum_k b_k w_k,i / sum_k b_k`, exact in
//! `i128` (below 2^125) and rounded half away from zero. Always [`STEPS`] steps, no early stop.
//! Sample counts are ignored; defined for `q >= 2f + 1`.
//!
//! Used: the `q - f` submissions nearest the result in L1 (nearest first, ties to the earlier
//! submission).

use super::{isqrt, mean, nearest, squared_distance, Aggregate, Input};
use crate::contract::payout::div_round_half_away;

/// Weiszfeld steps per aggregation.
pub const STEPS: usize = 8;

/// The geometric median after [`STEPS`] steps.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let models: Vec<&[i64]> = inputs.iter().map(|s| s.weights).collect();
    let mut z = mean(&models);
    for _ in 0..STEPS {
        let b: Vec<i128> = models
            .iter()
            .map(|w| {
                let d = isqrt(squared_distance(w, &z)).max(1);
                i128::try_from((1u128 << 64) / d).expect("below 2^65")
            })
            .collect();
        let total: i128 = b.iter().sum();
        z = (0..z.len())
            .map(|i| {
                let num: i128 = models
                    .iter()
                    .zip(&b)
                    .map(|(w, &bk)| bk * i128::from(w[i]))
                    .sum();
                i64::try_from(div_round_half_away(num, total)).expect("a weighted mean of i64")
            })
            .collect();
    }
    let used = nearest(inputs, &z, inputs.len().saturating_sub(f).max(1));
    Aggregate { weights: z, used }
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn moves_from_the_mean_to_the_cluster() {
        // Mean of 0, 0, 0, 10 = 2.5 -> 3; distances 3, 3, 3, 7:
        // z = 10 b(7) / (3 b(3) + b(7)) = 1.25 -> 1; distances 1, 1, 1, 9: z = 0.36 -> 0;
        // then distances 1 (floored), 1, 1, 10: z = 0.32 -> 0, and it stays.
        let a = aggregate(
            &inputs_of(&[(&[0], 1), (&[0], 1), (&[0], 1), (&[10], 1_000_000)]),
            1,
        );
        assert_eq!(a.weights, vec![0]);
        assert_eq!(a.used, vec![0, 1, 2]);
    }

    #[test]
    fn symmetric_points_keep_their_center() {
        let a = aggregate(
            &inputs_of(&[(&[0, 0], 1), (&[2, 0], 1), (&[0, 2], 1), (&[2, 2], 1)]),
            1,
        );
        assert_eq!(a.weights, vec![1, 1]);
    }
}

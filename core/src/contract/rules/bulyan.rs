//! `bulyan` (El Mhamdi et al., 2018): choose `theta = q - 2f` models by iterated Krum, then
//! take a coordinate-wise trimmed mean of the chosen. Needs `q >= 4f + 3`; sample counts are
//! ignored.
//!
//! Selection: while fewer than `theta` are chosen, score the `r` models not yet chosen by Krum
//! among themselves with `m = max(r - f - 2, 1)` nearest (squared Euclidean, exact), choose the
//! smallest score (ties: the earlier submission) and remove it. Aggregation: for each weight,
//! sort the `theta` chosen values, drop the `f` smallest and `f` largest, and average the
//! `theta - 2f` left (at least 3), rounded half away from zero.
//!
//! Used: the `theta` chosen models, in the order they were chosen.

use super::{krum_scores, Aggregate, Input};
use crate::contract::payout::div_round_half_away;

/// Iterated Krum then the trimmed mean of the chosen.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let q = inputs.len();
    let theta = q - 2 * f;
    let mut remaining: Vec<usize> = (0..q).collect();
    let mut chosen = Vec::with_capacity(theta);
    while chosen.len() < theta {
        let models: Vec<&[i64]> = remaining.iter().map(|&i| inputs[i].weights).collect();
        let m = models.len().saturating_sub(f + 2).max(1);
        let scores = krum_scores(&models, m);
        let best = (0..models.len())
            .min_by_key(|&k| (scores[k], remaining[k]))
            .expect("theta <= q models remain");
        chosen.push(remaining.remove(best));
    }
    let len = inputs[0].weights.len();
    let mut column = vec![0i64; theta];
    let kept = (theta - 2 * f) as i128;
    let weights = (0..len)
        .map(|i| {
            for (slot, &k) in column.iter_mut().zip(&chosen) {
                *slot = inputs[k].weights[i];
            }
            column.sort_unstable();
            let sum: i128 = column[f..theta - f].iter().map(|&w| i128::from(w)).sum();
            i64::try_from(div_round_half_away(sum, kept)).expect("a mean of i64")
        })
        .collect();
    Aggregate {
        weights,
        used: chosen,
    }
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn iterated_krum_then_trimmed_mean() {
        // q = 7, f = 1: theta = 5. Models 0, 1, 2, 3, 4, 50, -40.
        // Round 1 (m = 4): scores 30, 15, 10, 15, 30, 9030, 6894 -> 2.
        // Round 2 (m = 3): 0: 26, 1: 14, 3: 14, 4: 26 -> 1 (tie with 3, earlier).
        // Round 3 (m = 2): 0: 25, 3: 10, 4: 17 -> 3.
        // Round 4 (m = 1): 0: 16, 4: 16, 50: 2116, -40: 1600 -> 0.
        // Round 5 (m = 1): 4: 1936, 50: 2116, -40: 1936 -> 4.
        // Chosen 2, 1, 3, 0, 4; trimmed mean of 1, 2, 3 = 2.
        let models: Vec<[i64; 1]> = [0, 1, 2, 3, 4, 50, -40].iter().map(|&w| [w]).collect();
        let pairs: Vec<(&[i64], u64)> = models.iter().map(|w| (&w[..], 1)).collect();
        let a = aggregate(&inputs_of(&pairs), 1);
        assert_eq!(a.weights, vec![2]);
        assert_eq!(a.used, vec![2, 1, 3, 0, 4]);
    }
}

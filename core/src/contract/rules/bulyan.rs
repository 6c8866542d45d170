//! `bulyan` (El Mhamdi, Guerraoui and Rouault, 2018, "The Hidden Vulnerability of Distributed
//! Learning in Byzantium", ICML): choose `theta = q - 2f` models by iterated Krum, then for
//! each weight average the `beta = theta - 2f` chosen values closest to their median. Needs
//! `q >= 4f + 3`; sample counts are ignored.
//!
//! Selection: while fewer than `theta` are chosen, score the `r` models not yet chosen by Krum
//! among themselves with `m = max(r - f - 2, 1)` nearest (squared Euclidean, exact), choose the
//! smallest score (ties: the earlier submission) and remove it. Aggregation (the paper's
//! second step, as Flower's `aggregate_bulyan`): for each weight, the median of the `theta`
//! chosen values, then the mean of the `beta` (at least 3) closest to it, rounded half away
//! from zero, ties in distance to the smaller value ([`super::meamed::mean_around_median`]).
//! Until issue #33 this step was a trimmed mean (drop the `f` smallest and `f` largest), which
//! is not the paper's: with q = 7, f = 1 and models 0.5, 0.7, 0.7, 0.5, 0.7, 0.4, 0.7 it gave
//! 0.6333 where Bulyan gives 0.7.
//!
//! Used: the `theta` chosen models, in the order they were chosen.

use super::meamed::mean_around_median;
use super::{coordinatewise, krum_scores, Aggregate, Input};

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Bulyan;

impl super::AggregationRule for Bulyan {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// Iterated Krum, then the coordinate-wise mean of the `beta` chosen values around the median.
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
    let beta = theta - 2 * f;
    let models: Vec<&[i64]> = chosen.iter().map(|&k| inputs[k].weights).collect();
    let weights = coordinatewise(&models, |column| mean_around_median(column, beta));
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
    fn the_second_step_averages_around_the_median() {
        // Issue #33: q = 7, f = 1 (theta 5, beta 3), scalar models 0.5, 0.7, 0.7, 0.5, 0.7,
        // 0.4, 0.7 (scale 10). Krum rounds: m = 4 -> 1 (0.7s score 4, 0.5s 9, 0.4 20);
        // m = 3 -> 2 (0.7s 4, 0.5s 5); m = 2 -> 0 (0.5s 1, 0.7s 4); m = 1 -> 4 (0.7s 0);
        // m = 1 -> 3 (0.5 and 0.4 score 1, 0.7 4; 3 is earlier than 5).
        // Chosen 0.7, 0.7, 0.5, 0.7, 0.5: median 0.7, the 3 closest are the three 0.7s -> 0.7
        // (the old trimmed mean of 0.5, 0.7, 0.7 gave 0.6333).
        let models: Vec<[i64; 1]> = [5, 7, 7, 5, 7, 4, 7].iter().map(|&w| [w]).collect();
        let pairs: Vec<(&[i64], u64)> = models.iter().map(|w| (&w[..], 1)).collect();
        let a = aggregate(&inputs_of(&pairs), 1);
        assert_eq!(a.used, vec![1, 2, 0, 4, 3]);
        assert_eq!(a.weights, vec![7]);
        // The same at the fixed-point scale, where the old rule's 0.6333 is 633333333 units.
        let scale = 1_000_000_000 / 10;
        let models: Vec<[i64; 1]> = models.iter().map(|w| [w[0] * scale]).collect();
        let pairs: Vec<(&[i64], u64)> = models.iter().map(|w| (&w[..], 1)).collect();
        assert_eq!(aggregate(&inputs_of(&pairs), 1).weights, vec![7 * scale]);
    }

    #[test]
    fn iterated_krum_then_the_mean_around_the_median() {
        // q = 7, f = 1: theta = 5. Models 0, 1, 2, 3, 4, 50, -40.
        // Round 1 (m = 4): scores 30, 15, 10, 15, 30, 9030, 6894 -> 2.
        // Round 2 (m = 3): 0: 26, 1: 14, 3: 14, 4: 26 -> 1 (tie with 3, earlier).
        // Round 3 (m = 2): 0: 25, 3: 10, 4: 17 -> 3.
        // Round 4 (m = 1): 0: 16, 4: 16, 50: 2116, -40: 1600 -> 0.
        // Round 5 (m = 1): 4: 1936, 50: 2116, -40: 1936 -> 4.
        // Chosen 2, 1, 3, 0, 4; values 0..=4, median 2, the 3 closest 1, 2, 3: mean 2.
        let models: Vec<[i64; 1]> = [0, 1, 2, 3, 4, 50, -40].iter().map(|&w| [w]).collect();
        let pairs: Vec<(&[i64], u64)> = models.iter().map(|w| (&w[..], 1)).collect();
        let a = aggregate(&inputs_of(&pairs), 1);
        assert_eq!(a.weights, vec![2]);
        assert_eq!(a.used, vec![2, 1, 3, 0, 4]);
    }
}

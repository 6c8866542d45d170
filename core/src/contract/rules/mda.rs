//! `mda`: minimum-diameter averaging (El Mhamdi, Guerraoui, Guirguis, Hoang and Rouault, 2020,
//! "Genuinely Distributed Byzantine Machine Learning", PODC; ByzFL's `MDA`). Among all subsets
//! of `q - f` models, the one whose diameter (largest pairwise Euclidean distance) is smallest;
//! its unweighted mean, rounded half away from zero, is the new model. Defined for
//! `q >= 2f + 1`; sample counts are ignored.
//!
//! Exact: diameters compare as squared distances in `u128`. Subsets are visited in
//! lexicographic order of their sorted indices (as `itertools.combinations`, which ByzFL
//! walks) and a later subset replaces the best only with a strictly smaller diameter, so ties
//! go to the lexicographically first subset, as in ByzFL.
//!
//! Cost: `C(q, f)` subsets. Validation refuses a quorum and `f` with more than
//! [`crate::config::MDA_MAX_SUBSETS`] ([`crate::config::mda_subsets`]), naming the keys;
//! within it one aggregation is at most 2^20 subsets, each diameter found by walking the
//! pairs from the farthest down (usually a few).
//!
//! Used: the chosen subset, nearest (L1) to the result first, ties to the earlier submission.

use super::{mean, models_of, squared_distance, Aggregate, Input};
use crate::contract::payout;

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Mda;

impl super::AggregationRule for Mda {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// The mean of the minimum-diameter `q - f` subset.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let q = inputs.len();
    let keep = q.saturating_sub(f).max(1);
    let chosen = min_diameter_subset(&models_of(inputs), keep);
    let models: Vec<&[i64]> = chosen.iter().map(|&k| inputs[k].weights).collect();
    let weights = mean(&models);
    let mut used = chosen;
    used.sort_by_key(|&k| (payout::distance_units(inputs[k].weights, &weights), k));
    Aggregate { weights, used }
}

/// The lexicographically first `keep`-subset of `models` (indices ascending) of the smallest
/// diameter.
pub fn min_diameter_subset(models: &[&[i64]], keep: usize) -> Vec<usize> {
    let q = models.len();
    // Every pair, farthest first: a subset's diameter is the first pair with both ends kept.
    let mut pairs: Vec<(u128, usize, usize)> = Vec::with_capacity(q * (q - 1) / 2);
    for i in 0..q {
        for j in i + 1..q {
            pairs.push((squared_distance(models[i], models[j]), i, j));
        }
    }
    pairs.sort_unstable_by(|a, b| b.cmp(a));
    let mut kept = vec![false; q];
    let mut subset: Vec<usize> = (0..keep).collect();
    let mut best: Option<(u128, Vec<usize>)> = None;
    loop {
        kept.iter_mut().for_each(|k| *k = false);
        subset.iter().for_each(|&i| kept[i] = true);
        let diameter = pairs
            .iter()
            .find(|&&(_, i, j)| kept[i] && kept[j])
            .map_or(0, |&(d, _, _)| d);
        if best.as_ref().is_none_or(|(d, _)| diameter < *d) {
            best = Some((diameter, subset.clone()));
        }
        // The next combination in lexicographic order: bump the last index that can move.
        let Some(pos) = (0..keep).rev().find(|&p| subset[p] < q - keep + p) else {
            break;
        };
        subset[pos] += 1;
        for p in pos + 1..keep {
            subset[p] = subset[p - 1] + 1;
        }
    }
    best.expect("at least one subset").1
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;
    use crate::config::mda_subsets as subsets;

    #[test]
    fn averages_the_tightest_subset() {
        // q = 5, f = 2, keep 3. Models 0, 1, 3, 10, 11 (1-D): diameters of the 3-subsets:
        // {0, 1, 3} 3, {1, 3, 10} 9, {3, 10, 11} 8, any with 0 and 10 or 11 >= 10. The first
        // is the smallest: mean 4 / 3 = 1.33 -> 1.
        let a = aggregate(
            &inputs_of(&[(&[0], 1), (&[1], 1), (&[3], 1), (&[10], 1), (&[11], 9)]),
            2,
        );
        assert_eq!(a.weights, vec![1]);
        // L1 to 1: 1, 0, 2.
        assert_eq!(a.used, vec![1, 0, 2]);
    }

    #[test]
    fn ties_go_to_the_lexicographically_first_subset() {
        // q = 4, f = 1: models 0, 2, 4, 6; {0, 2, 4} and {2, 4, 6} both have diameter 4;
        // {0, 1, 2} comes first: mean 2.
        let a = aggregate(&inputs_of(&[(&[0], 1), (&[2], 1), (&[4], 1), (&[6], 1)]), 1);
        assert_eq!(a.weights, vec![2]);
        assert_eq!(a.used, vec![1, 0, 2]);
        // Reversed order: 6, 4, 2, 0 -> {0, 1, 2} = models 6, 4, 2: mean 4.
        let a = aggregate(&inputs_of(&[(&[6], 1), (&[4], 1), (&[2], 1), (&[0], 1)]), 1);
        assert_eq!(a.weights, vec![4]);
    }

    #[test]
    fn the_diameter_is_euclidean_over_every_weight() {
        // 2-D: (0, 0), (3, 4), (0, 5), (100, 0), f = 1, keep 3. {0, 1, 2}: squared distances
        // 25, 25, 10 -> 25; every subset with (100, 0) is farther. Mean (1, 3).
        let a = aggregate(
            &inputs_of(&[(&[0, 0], 1), (&[3, 4], 1), (&[0, 5], 1), (&[100, 0], 1)]),
            1,
        );
        assert_eq!(a.weights, vec![1, 3]);
    }

    #[test]
    fn subsets_counts_and_caps() {
        assert_eq!(subsets(7, 1), Some(7));
        assert_eq!(subsets(10, 3), Some(120));
        assert_eq!(subsets(5, 0), Some(1));
        assert_eq!(subsets(30, 10), None); // 30045015 > 2^20
        assert_eq!(subsets(10_000, 1), Some(10_000));
        assert_eq!(subsets(10_000, 4_999), None);
    }
}

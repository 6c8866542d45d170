//! `monna`: the mean of the nearest neighbours of a trusted pivot (Farhadkhani, Guerraoui,
//! Gupta, Hoang, Pinot and Stephan, 2023, "Robust Collaborative Learning with Linear Gradient
//! Overhead", ICML; ByzFL's `MoNNA(f, idx)`). The `q - f` models nearest the pivot in
//! Euclidean distance (squared, exact in `u128`; ties to the earlier submission) are averaged
//! without weights, rounded half away from zero ([`nearest_mean`]). Defined for `q >= 2f + 1`;
//! sample counts are ignored.
//!
//! The pivot: in the paper and in ByzFL it is an honest node's own vector (`idx`), honest by
//! assumption. The contract has no submission it may assume honest (the first in chain order
//! is whoever got in first, a Byzantine robot as easily as an honest one); the one vector
//! every honest robot trusts is the shared model `w(t)` the round was opened on, from which
//! every honest submission started. So the pivot here is `w(t)`. The consequence to know: a
//! model that barely moves from `w(t)` (a lazy or stale robot) is among the nearest.
//! `tests/byzfl.rs` checks [`nearest_mean`] with ByzFL's pivot (the first vector, which is
//! then one of the `q`) against ByzFL.
//!
//! Used: the `q - f` chosen, nearest the pivot first.

use super::{mean, models_of, squared_distance, Aggregate, Input};

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Monna;

impl super::AggregationRule for Monna {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.current, round.inputs, round.f)
    }
}

/// The mean of the `q - f` submissions nearest the shared model `current`.
pub fn aggregate(current: &[i64], inputs: &[Input], f: usize) -> Aggregate {
    let models = models_of(inputs);
    let (weights, used) = nearest_mean(current, &models, models.len().saturating_sub(f).max(1));
    Aggregate { weights, used }
}

/// The mean of the `keep` models nearest `pivot` (squared Euclidean, ties to the lower
/// index), and their indices nearest first.
pub fn nearest_mean(pivot: &[i64], models: &[&[i64]], keep: usize) -> (Vec<i64>, Vec<usize>) {
    let distances: Vec<u128> = models.iter().map(|w| squared_distance(w, pivot)).collect();
    let mut order: Vec<usize> = (0..models.len()).collect();
    order.sort_by_key(|&k| (distances[k], k));
    order.truncate(keep.clamp(1, models.len()));
    let chosen: Vec<&[i64]> = order.iter().map(|&k| models[k]).collect();
    (mean(&chosen), order)
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn averages_the_models_nearest_the_shared_model() {
        // Pivot (0, 0); q = 5, f = 2, keep 3. Squared distances: (1, 1) 2, (-2, 0) 4,
        // (0, 3) 9, (10, 10) 200, (2, -1) 5 -> 0, 1, 4: mean (1 / 3, 0) -> (0, 0).
        let a = aggregate(
            &[0, 0],
            &inputs_of(&[
                (&[1, 1], 1),
                (&[-2, 0], 1),
                (&[0, 3], 1),
                (&[10, 10], 9),
                (&[2, -1], 1),
            ]),
            2,
        );
        assert_eq!(a.weights, vec![0, 0]);
        assert_eq!(a.used, vec![0, 1, 4]);
    }

    #[test]
    fn equal_distances_go_to_the_earlier_submission() {
        // Pivot 5: models 7, 3, 5, 100 (distances 4, 4, 0, 9025), keep 3 with f = 1:
        // 5, 7, 3 -> mean 5; keeping 2: 5, 7 -> 6.
        let inputs = inputs_of(&[(&[7], 1), (&[3], 1), (&[5], 1), (&[100], 1)]);
        let a = aggregate(&[5], &inputs, 1);
        assert_eq!((a.weights, a.used), (vec![5], vec![2, 0, 1]));
        let models = models_of(&inputs);
        assert_eq!(nearest_mean(&[5], &models, 2), (vec![6], vec![2, 0]));
    }
}

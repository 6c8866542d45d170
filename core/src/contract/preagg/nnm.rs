//! `nnm`, nearest-neighbour mixing (Allouah et al., "Fixing by Mixing: A Recipe for Optimal
//! Byzantine ML under Heterogeneity", AISTATS 2023): every model is replaced by the mean of
//! its `n - f` nearest models (itself included, at distance 0),
//!
//! `y_i = (1 / (n - f)) sum_{j in N_i} x_j`, `N_i` the `n - f` indices of the smallest
//! `|x_i - x_j|^2`,
//!
//! so that a Byzantine model can move each mixed model by at most `f / (n - f)` of its offset,
//! and the honest mixed models are closer together than the honest models were (the paper's
//! variance reduction, which lets any rule after it reach the optimal error under
//! heterogeneity). `n` is the number of models entering the stage.
//!
//! Integers: squared distances exact in `u128`; neighbours ordered by (distance, index), so a
//! tie goes to the earlier model (ByzFL's `argpartition` leaves ties unspecified); the mean
//! rounds half away from zero. Samples of `y_i` are those of `x_i` (the mixed model stands for
//! its own submission). Needs `f < n` (validation).

use super::{mean_of, Staged};
use crate::contract::rules::squared_distance;

/// The stage as its line in the [`Preaggregator`](crate::config::Preaggregator) registry
/// names it.
pub struct Nnm;

impl super::Stage for Nnm {
    fn apply(&self, models: &[Staged], stage: &super::StageInput) -> Vec<Staged> {
        apply(models, stage.params.assumed_f as usize)
    }
}

/// Each model mixed with its `n - f` nearest neighbours.
pub fn apply(models: &[Staged], f: usize) -> Vec<Staged> {
    let n = models.len();
    assert!(f < n, "nnm needs f < n (f = {f}, n = {n})");
    let keep = n - f;
    let mut d = vec![vec![0u128; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let v = squared_distance(&models[i].weights, &models[j].weights);
            d[i][j] = v;
            d[j][i] = v;
        }
    }
    (0..n)
        .map(|i| {
            let mut order: Vec<usize> = (0..n).collect();
            order.sort_by_key(|&j| (d[i][j], j));
            let neighbours: Vec<&Staged> = order[..keep].iter().map(|&j| &models[j]).collect();
            Staged {
                weights: mean_of(&neighbours).weights,
                samples: models[i].samples,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::staged_of;
    use super::*;

    fn weights(out: &[Staged]) -> Vec<Vec<i64>> {
        out.iter().map(|s| s.weights.clone()).collect()
    }

    #[test]
    fn each_model_becomes_the_mean_of_its_nearest() {
        // n = 4, f = 1: three neighbours each.
        // 0: distances to 0, 2, 4, 100 -> {0, 2, 4}: 6 / 3 = 2.
        // 2: 2, 0, 2, 98 -> {2, 0, 4}: 2.
        // 4: 4, 2, 0, 96 -> {4, 2, 0}: 2.
        // 100: 100, 98, 96, 0 -> {100, 4, 2}: 106 / 3 = 35.33 -> 35.
        let out = apply(&staged_of(&[&[0], &[2], &[4], &[100]]), 1);
        assert_eq!(weights(&out), vec![vec![2], vec![2], vec![2], vec![35]]);
    }

    #[test]
    fn ties_take_the_earlier_model_and_round_half_away() {
        // n = 3, f = 1: two neighbours. Model 1 (value 0) is at distance 1 from both -1 and 1:
        // it takes itself and the earlier, -1: -1 / 2 = -0.5 -> -1.
        // Model 0 (-1): itself and 0 -> -0.5 -> -1. Model 2 (1): itself and 0 -> 0.5 -> 1.
        let out = apply(&staged_of(&[&[-1, 5], &[0, 5], &[1, 5]]), 1);
        assert_eq!(weights(&out), vec![vec![-1, 5], vec![-1, 5], vec![1, 5]]);
    }

    #[test]
    fn f_zero_is_the_mean_for_everyone() {
        let out = apply(&staged_of(&[&[0, 3], &[3, 0], &[6, 6]]), 0);
        assert_eq!(weights(&out), vec![vec![3, 3]; 3]);
    }

    #[test]
    fn samples_stay_with_their_model() {
        let mut models = staged_of(&[&[0], &[1], &[9]]);
        models[2].samples = 7;
        assert_eq!(apply(&models, 1)[2].samples, 7);
    }
}

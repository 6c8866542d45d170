//! `arc`, adaptive robust clipping (Allouah, Guerraoui, Gupta, Jellouli, Rizk and Stephan,
//! "Boosting Robustness by Clipping Gradients in Distributed Learning", 2024): the
//! `k = floor(2 f (n - f) / n)` updates of largest norm are clipped to the norm of the largest
//! update left unclipped,
//!
//! `r = |x|_(n - k)` (the `(n - k)`-th smallest norm), `y_k = w(t) + x_k min(1, r / |x_k|)`,
//!
//! with `x_k = w_k - w(t)` and `n` the models entering the stage. The radius follows the round
//! instead of a fixed guess: with `f` Byzantine models at most `f` of the clipped ones can be
//! honest, and a Byzantine update ends no longer than an honest one. `k = 0` (f = 0, or
//! `n` small) clips nothing.
//!
//! Integers: norms `floor(sqrt(.))` of exact squared distances, ordered by (norm, index), so
//! of equal norms the later model is the one clipped; scaling as [`super::clip_to`]. Samples
//! unchanged. Needs `f < n` (validation).

use super::{clip_to, Staged};
use crate::contract::rules::{isqrt, squared_distance};

/// How many updates ARC clips among `n` with `f` assumed Byzantine: `floor(2 f (n - f) / n)`.
pub fn clipped_count(n: usize, f: usize) -> usize {
    if n == 0 || f >= n {
        return 0;
    }
    2 * f * (n - f) / n
}

/// The stage as its line in the [`Preaggregator`](crate::config::Preaggregator) registry
/// names it.
pub struct Arc;

impl super::Stage for Arc {
    fn apply(&self, models: &[Staged], stage: &super::StageInput) -> Vec<Staged> {
        apply(models, stage.current, stage.params.assumed_f as usize)
    }
}

/// The models with their `clipped_count` longest updates clipped to the next one's norm.
pub fn apply(models: &[Staged], current: &[i64], f: usize) -> Vec<Staged> {
    let n = models.len();
    let k = clipped_count(n, f);
    let mut out = models.to_vec();
    if k == 0 {
        return out;
    }
    let norms: Vec<u128> = models
        .iter()
        .map(|m| isqrt(squared_distance(&m.weights, current)))
        .collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| (norms[i], i));
    let radius = norms[order[n - k - 1]];
    for &i in &order[n - k..] {
        out[i].weights = clip_to(&models[i].weights, current, radius);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::staged_of;
    use super::*;

    #[test]
    fn the_clipped_count_follows_the_paper() {
        assert_eq!(clipped_count(10, 1), 1); // 18 / 10
        assert_eq!(clipped_count(10, 3), 4); // 42 / 10
        assert_eq!(clipped_count(5, 2), 2); // 12 / 5
        assert_eq!(clipped_count(7, 0), 0);
        assert_eq!(clipped_count(3, 3), 0);
    }

    #[test]
    fn the_longest_updates_take_the_next_norm() {
        // n = 5, f = 2: k = floor(2 * 2 * 3 / 5) = 2. Norms around 0: 1, 3, 2, 50, 10.
        // Sorted: 1 (0), 2 (2), 3 (1), 10 (4), 50 (3); r = 3; clip models 4 and 3:
        // 10 -> 3, 50 -> 3; the rest unchanged.
        let out = apply(&staged_of(&[&[1], &[-3], &[2], &[50], &[10]]), &[0], 2);
        let w: Vec<i64> = out.iter().map(|s| s.weights[0]).collect();
        assert_eq!(w, vec![1, -3, 2, 3, 3]);
    }

    #[test]
    fn around_the_shared_model_in_two_dimensions() {
        // n = 4, f = 1: k = floor(2 * 3 / 4) = 1. Around (100, 100): updates (3, 4) norm 5,
        // (0, 1) norm 1, (-6, 8) norm 10, (1, 1) norm 1 (floor sqrt 2). r = 5 (the third
        // smallest); (-6, 8) -> (-3, 4).
        let out = apply(
            &staged_of(&[&[103, 104], &[100, 101], &[94, 108], &[101, 101]]),
            &[100, 100],
            1,
        );
        assert_eq!(out[2].weights, vec![97, 104]);
        assert_eq!(out[0].weights, vec![103, 104]);
    }
}

//! `dnc`: divide and conquer (Shejwalkar and Houmansadr, 2021, "Manipulating the Byzantine:
//! Optimizing Model Poisoning Attacks and Defenses for Federated Learning", NDSS; Blades'
//! `DnC`). Center the models on their mean, find the top principal direction `v` of the
//! centered models, score each model by its squared projection `((w_k - mu) . v)^2`, and
//! average the `q - f` models with the smallest scores (the `f` that stick out most along the
//! direction of largest spread are dropped). Defined for `q >= 2f + 1`; sample counts are
//! ignored.
//!
//! Integer version:
//! - `mu` = the unweighted mean rounded half away from zero; `x_k = w_k - mu` (below 2^49).
//! - The `q x q` Gram matrix `G_jk = x_j . x_k`, exact in `i128` (below 2^114). The top right
//!   singular vector of the centered matrix is `X^T u / |X^T u|` for `u` the top eigenvector of
//!   `G`, and `x_k . v` is proportional to `(G u)_k`, so the scores need only `G`'s
//!   eigenvector: `q x q` work instead of `len x len`.
//! - `G' = G >> s` (arithmetic shift, rounding toward minus infinity) with the smallest `s`
//!   that brings every `|G'_jk|` below 2^62.
//! - Power iteration, always [`POWER_STEPS`] steps in index order: start from `u = G' e_j`
//!   for `j` the model of the largest `G_jj` (the farthest from the mean; ties to the lower
//!   index), which is never orthogonal to the top eigenvector unless that model has no
//!   component along it; each step `y = G' u`, then `u = y * 2^31 / max_k |y_k|` rounded half
//!   away from zero (`|u_k| <= 2^31`, so `|y_k| < 2^107`). A zero `y` (all models equal)
//!   stops it with every score 0.
//! - Score `s_k = |(G' u)_k|` after the last step (the order of `(x_k . v)^2`); the `q - f`
//!   smallest are kept (ties to the earlier submission) and their mean, rounded half away
//!   from zero, is the new model.
//!
//! Differences from Blades: Blades projects on a random subset of `sub_dim = 10000`
//! coordinates, `num_iters = 5` times, and keeps the union of the iterations' good sets. With
//! at most 10000 weights (the paper's model has 2848) the subset is every coordinate, every
//! iteration computes the same scores and the union is one good set, which is what this rule
//! computes; above 10000 weights this rule still uses every coordinate (no randomness in the
//! contract). Blades takes an exact SVD; this takes a fixed-count power iteration.
//!
//! Used: the `q - f` kept, smallest score first.

use super::{mean, models_of, Aggregate, Input};
use crate::contract::payout::div_round_half_away;

/// Power-iteration steps per aggregation.
pub const POWER_STEPS: usize = 64;

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Dnc;

impl super::AggregationRule for Dnc {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// The mean of the `q - f` models with the smallest projections on the top direction.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let models = models_of(inputs);
    let keep = models.len().saturating_sub(f).max(1);
    let scores = scores(&models);
    let mut order: Vec<usize> = (0..models.len()).collect();
    order.sort_by_key(|&k| (scores[k], k));
    order.truncate(keep);
    let chosen: Vec<&[i64]> = order.iter().map(|&k| models[k]).collect();
    Aggregate {
        weights: mean(&chosen),
        used: order,
    }
}

/// Each model's score `|(G' u)_k|` (ordered as its squared projection on the top principal
/// direction of the centered models).
pub fn scores(models: &[&[i64]]) -> Vec<u128> {
    let q = models.len();
    let mu = mean(models);
    let x: Vec<Vec<i128>> = models
        .iter()
        .map(|w| {
            w.iter()
                .zip(&mu)
                .map(|(&a, &m)| i128::from(a) - i128::from(m))
                .collect()
        })
        .collect();
    let mut g = vec![vec![0i128; q]; q];
    for j in 0..q {
        for k in j..q {
            let v: i128 = x[j].iter().zip(&x[k]).map(|(&a, &b)| a * b).sum();
            g[j][k] = v;
            g[k][j] = v;
        }
    }
    let max = g
        .iter()
        .flatten()
        .map(|v| v.unsigned_abs())
        .max()
        .unwrap_or(0);
    let shift = (128 - max.leading_zeros()).saturating_sub(62);
    g.iter_mut().flatten().for_each(|v| *v >>= shift);
    let times = |u: &[i128]| -> Vec<i128> {
        g.iter()
            .map(|row| row.iter().zip(u).map(|(&a, &b)| a * b).sum())
            .collect()
    };
    // Start: G' e_j, the column of the model with the largest G_jj.
    let j = (0..q)
        .max_by_key(|&k| (g[k][k], std::cmp::Reverse(k)))
        .expect("q >= 1");
    let mut y: Vec<i128> = (0..q).map(|k| g[k][j]).collect();
    for _ in 0..POWER_STEPS {
        let top = y.iter().map(|v| v.unsigned_abs()).max().unwrap_or(0);
        if top == 0 {
            break;
        }
        let top = i128::try_from(top).expect("below 2^107");
        let u: Vec<i128> = y
            .iter()
            .map(|&v| div_round_half_away(v << 31, top))
            .collect();
        y = times(&u);
    }
    y.iter().map(|v| v.unsigned_abs()).collect()
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn drops_the_model_farthest_along_the_main_direction() {
        // q = 5, f = 1. 1-D models 0, 1, 2, 3, 14: mean 4, centered -4, -3, -2, -1, 10; G is
        // the rank-one x x^T, so u is proportional to x and the scores to |x_k|: 4, 3, 2, 1,
        // 10. Keep 3, 2, 1, 0 (scores 1, 2, 3, 4): mean 6 / 4 = 1.5 -> 2.
        let a = aggregate(
            &inputs_of(&[(&[0], 1), (&[1], 1), (&[2], 1), (&[3], 1), (&[14], 1)]),
            1,
        );
        assert_eq!(a.used, vec![3, 2, 1, 0]);
        assert_eq!(a.weights, vec![2]);
    }

    #[test]
    fn the_direction_is_found_in_several_dimensions() {
        // Four models spread a little along y, one far along x: (0, 1), (0, -1), (0, 2),
        // (0, -2), (20, 0). Mean (4, 0); centered (-4, 1), (-4, -1), (-4, 2), (-4, -2),
        // (16, 0). The top direction is x (variance 320 against 10 along y): projections
        // -4, -4, -4, -4, 16. f = 1 drops the far one; the other four tie and keep their
        // order: mean (0, 0).
        let a = aggregate(
            &inputs_of(&[
                (&[0, 1], 1),
                (&[0, -1], 1),
                (&[0, 2], 1),
                (&[0, -2], 1),
                (&[20, 0], 1),
            ]),
            1,
        );
        assert_eq!(a.used, vec![0, 1, 2, 3]);
        assert_eq!(a.weights, vec![0, 0]);
    }

    #[test]
    fn equal_models_score_zero_and_keep_submission_order() {
        let a = aggregate(&inputs_of(&[(&[5], 1), (&[5], 1), (&[5], 1)]), 1);
        assert_eq!(a.used, vec![0, 1]);
        assert_eq!(a.weights, vec![5]);
    }

    #[test]
    fn scores_order_as_exact_projections_on_a_random_round() {
        // 9 models of 6 weights with one direction of large spread plus noise: the integer
        // scores must order the models as the f64 projections on the top eigenvector found
        // by 500 f64 power steps.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % 2_000_001) as i64 - 1_000_000
        };
        let dir = [3i64, -1, 2, 0, 1, -2];
        let models: Vec<Vec<i64>> = (0..9)
            .map(|k| {
                let t = (k as i64 - 4) * 10_000_000;
                dir.iter().map(|&d| d * t + next()).collect()
            })
            .collect();
        let refs: Vec<&[i64]> = models.iter().map(|w| &w[..]).collect();
        let s = scores(&refs);
        let mu: Vec<f64> = (0..6)
            .map(|i| models.iter().map(|w| w[i] as f64).sum::<f64>() / 9.0)
            .collect();
        let x: Vec<Vec<f64>> = models
            .iter()
            .map(|w| w.iter().zip(&mu).map(|(&a, &m)| a as f64 - m).collect())
            .collect();
        let mut v = vec![1.0f64; 6];
        for _ in 0..500 {
            let p: Vec<f64> = x
                .iter()
                .map(|r| r.iter().zip(&v).map(|(a, b)| a * b).sum())
                .collect();
            v = (0..6)
                .map(|i| x.iter().zip(&p).map(|(r, pk)| r[i] * pk).sum())
                .collect();
            let n = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            v.iter_mut().for_each(|a| *a /= n);
        }
        let exact: Vec<f64> = x
            .iter()
            .map(|r| r.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>().abs())
            .collect();
        let mut by_int: Vec<usize> = (0..9).collect();
        by_int.sort_by_key(|&k| (s[k], k));
        let mut by_f64: Vec<usize> = (0..9).collect();
        by_f64.sort_by(|&a, &b| exact[a].total_cmp(&exact[b]));
        assert_eq!(by_int, by_f64);
    }
}

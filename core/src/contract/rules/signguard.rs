//! `signguard` (Xu, Huang, Wang and Zhang, 2022, "SignGuard: Byzantine-robust Federated
//! Learning through Collaborative Malicious Gradient Filtering", ICDCS; Blades' `Signguard`).
//! Two filters on the updates `x_k = w_k - w(t)` (against the shared model the round opened
//! on), then the clipped mean of the updates both keep.
//!
//! - Norm filter: `n_k = floor(sqrt(|x_k|^2))`, `M` = the median of the `n_k` (the rounded
//!   mean of the two middle ones for an even `q`); keep the `k` with `M / 10 <= n_k <= 3M`
//!   (the paper's L = 0.1, R = 3.0, tested exactly as `10 n_k >= M` and `n_k <= 3M`). Blades
//!   clips before this test, which makes its upper bound moot; the paper tests the raw norm.
//! - Sign filter: each update's sign counts `(pos_k, neg_k, zero_k)` over every weight (the
//!   paper samples a random 10 % of the coordinates for speed; the contract has no
//!   randomness and counts them all), split in two clusters by 2-means (Blades uses k-means
//!   with 2 clusters), the larger one kept (the honest majority; a tie keeps the cluster of
//!   the earlier submission). The 2-means is exact integer Lloyd: the two initial centers are
//!   the pair of models whose counts are farthest apart (squared, ties to the
//!   lexicographically first pair), each model joins the nearer center (exact rational
//!   comparison; ties to the first), centers move to their members' mean, until nothing
//!   moves or [`LLOYD_STEPS`] passes.
//! - Aggregate: the kept set is both filters' intersection (the norm filter's set alone if
//!   that is empty, a case the paper leaves undefined); each kept update with `n_k > M` is
//!   scaled to norm `M` (`x_k,i * M / n_k`, rounded half away from zero), and
//!   `w_i = w(t)_i + sum_k c_k,i / |kept|`, rounded half away from zero. Each clipped
//!   contribution lies between 0 and `x_k,i`, so the result lies within the round's models
//!   and `w(t)`.
//!
//! `f` is not read (the rule finds its own outliers); like the other robust rules it is defined
//! for `q >= 2f + 1`. Sample counts are ignored. The kept set has no fixed size, so the number
//! of submissions paid varies (at least one).
//!
//! Used: the kept submissions, nearest (L1) to the result first, ties to the earlier one.

use super::{isqrt, median_of, squared_distance, Aggregate, Input};
use crate::contract::payout::{self, div_round_half_away};

/// The most 2-means passes per aggregation (it stops earlier when no model moves).
pub const LLOYD_STEPS: usize = 32;

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Signguard;

impl super::AggregationRule for Signguard {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.current, round.inputs, round.f)
    }
}

/// Norm filter, sign clustering, clipped mean.
pub fn aggregate(current: &[i64], inputs: &[Input], _f: usize) -> Aggregate {
    let q = inputs.len();
    let norms: Vec<u128> = inputs
        .iter()
        .map(|s| isqrt(squared_distance(s.weights, current)))
        .collect();
    let m = median_norm(&norms);
    let by_norm: Vec<bool> = norms.iter().map(|&n| 10 * n >= m && n <= 3 * m).collect();
    let features: Vec<[i64; 3]> = inputs
        .iter()
        .map(|s| {
            let mut c = [0i64; 3];
            for (&w, &v) in s.weights.iter().zip(current) {
                c[match w.cmp(&v) {
                    std::cmp::Ordering::Greater => 0,
                    std::cmp::Ordering::Less => 1,
                    std::cmp::Ordering::Equal => 2,
                }] += 1;
            }
            c
        })
        .collect();
    let by_sign = majority_cluster(&features);
    let mut kept: Vec<usize> = (0..q).filter(|&k| by_norm[k] && by_sign[k]).collect();
    if kept.is_empty() {
        kept = (0..q).filter(|&k| by_norm[k]).collect();
    }
    let m = i128::try_from(m).expect("a norm below 2^57");
    let mut sum = vec![0i128; current.len()];
    for &k in &kept {
        let n = i128::try_from(norms[k]).expect("a norm below 2^57");
        for ((acc, &w), &c) in sum.iter_mut().zip(inputs[k].weights).zip(current) {
            let x = i128::from(w) - i128::from(c);
            *acc += if n <= m {
                x
            } else {
                div_round_half_away(x * m, n)
            };
        }
    }
    let count = kept.len() as i128;
    let weights: Vec<i64> = current
        .iter()
        .zip(&sum)
        .map(|(&c, &s)| {
            i64::try_from(i128::from(c) + div_round_half_away(s, count))
                .expect("a clipped mean between the models")
        })
        .collect();
    kept.sort_by_key(|&k| (payout::distance_units(inputs[k].weights, &weights), k));
    Aggregate {
        weights,
        used: kept,
    }
}

/// The median of the norms: the middle one, or the rounded-up mean of the two middle ones.
fn median_norm(norms: &[u128]) -> u128 {
    // Norms are below 2^57, so they fit `median_of`'s i64.
    let mut v: Vec<i64> = norms
        .iter()
        .map(|&n| i64::try_from(n).expect("below 2^57"))
        .collect();
    median_of(&mut v).unsigned_abs().into()
}

/// Which models are in the larger of the two 2-means clusters of `features`.
pub fn majority_cluster(features: &[[i64; 3]]) -> Vec<bool> {
    let q = features.len();
    let dist = |a: &[i64; 3], b: &[i64; 3]| -> i128 {
        a.iter()
            .zip(b)
            .map(|(&x, &y)| i128::from(x - y) * i128::from(x - y))
            .sum()
    };
    let (mut a, mut b, mut far) = (0, 0, -1i128);
    for i in 0..q {
        for j in i + 1..q {
            let d = dist(&features[i], &features[j]);
            if d > far {
                (a, b, far) = (i, j, d);
            }
        }
    }
    if far <= 0 {
        return vec![true; q]; // one point (or all equal): one cluster
    }
    // Centers as (sum, count): the mean is sum / count.
    let mut centers = [(features[a], 1i64), (features[b], 1i64)];
    let mut label = vec![0usize; q];
    for pass in 0..LLOYD_STEPS {
        // |f - S / c|^2 = |c f - S|^2 / c^2; compare across centers by cross-multiplying.
        let scaled = |f: &[i64; 3], (s, c): ([i64; 3], i64)| -> (i128, i128) {
            let d: i128 = (0..3)
                .map(|i| {
                    let e = i128::from(c) * i128::from(f[i]) - i128::from(s[i]);
                    e * e
                })
                .sum();
            (d, i128::from(c) * i128::from(c))
        };
        let next: Vec<usize> = features
            .iter()
            .map(|f| {
                let (d0, c0) = scaled(f, centers[0]);
                let (d1, c1) = scaled(f, centers[1]);
                if centers[1].1 == 0 || (centers[0].1 != 0 && d0 * c1 <= d1 * c0) {
                    0
                } else {
                    1
                }
            })
            .collect();
        if pass > 0 && next == label {
            break;
        }
        label = next;
        centers = [([0; 3], 0), ([0; 3], 0)];
        for (f, &l) in features.iter().zip(&label) {
            for (c, &x) in centers[l].0.iter_mut().zip(f.iter()) {
                *c += x;
            }
            centers[l].1 += 1;
        }
    }
    let size1 = label.iter().filter(|&&l| l == 1).count();
    let keep = match (q - size1).cmp(&size1) {
        std::cmp::Ordering::Greater => 0,
        std::cmp::Ordering::Less => 1,
        std::cmp::Ordering::Equal => label[0],
    };
    label.iter().map(|&l| l == keep).collect()
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn sign_flipped_and_tiny_updates_are_filtered() {
        // Shared model (0, 0, 0, 0). Updates: three honest (1, 1, 1, -1)-like, one sign-flipped
        // (-2, -2, -2, 2), one almost still (0, 0, 0, 0).
        // Norms 2, 2, 2, 4, 0 -> median 2; norm filter 10 n >= 2 and n <= 6: drops the still
        // one. Sign counts (pos, neg, zero): (3, 1, 0) x 3, (1, 3, 0), (0, 0, 4).
        // Farthest pair: (3, 1, 0) vs (0, 0, 4) (9 + 1 + 16 = 26) = models 0 and 4. Pass 1:
        // (1, 3, 0) is 8 from (3, 1, 0) and 26 from (0, 0, 4): cluster 0 = {0, 1, 2, 3},
        // cluster 1 = {4}. Centers (10, 6, 0) / 4 and (0, 0, 4); pass 2 the same. Kept:
        // {0, 1, 2, 3} and the norm filter: {0, 1, 2, 3}; the flipped one (norm 4 > 2) is
        // clipped to (-1, -1, -1, 1). Sum (2, 2, 2, -2) / 4 = 0.5 -> 1 and -1.
        let a = aggregate(
            &[0, 0, 0, 0],
            &inputs_of(&[
                (&[1, 1, 1, -1], 1),
                (&[1, 1, 1, -1], 1),
                (&[1, 1, 1, -1], 1),
                (&[-2, -2, -2, 2], 1),
                (&[0, 0, 0, 0], 1),
            ]),
            1,
        );
        assert_eq!(a.weights, vec![1, 1, 1, -1]);
        // L1 to (1, 1, 1, -1): 0, 0, 0, 12.
        assert_eq!(a.used, vec![0, 1, 2, 3]);
    }

    #[test]
    fn the_sign_majority_drops_a_flipped_minority() {
        // Shared 10 (1-D, sign counts are (1, 0, 0) or (0, 1, 0)). Models 12, 13, 11, 7, 6:
        // updates 2, 3, 1, -3, -4, norms 2, 3, 1, 3, 4 -> median 3, norm filter keeps all
        // (10 n >= 3, n <= 9). Clusters (1, 0, 0) x 3 and (0, 1, 0) x 2: the first is larger.
        // Kept 0, 1, 2: no clipping (norms <= 3); mean update 6 / 3 = 2 -> 12.
        let a = aggregate(
            &[10],
            &inputs_of(&[(&[12], 1), (&[13], 1), (&[11], 1), (&[7], 1), (&[6], 1)]),
            1,
        );
        assert_eq!(a.weights, vec![12]);
        assert_eq!(a.used, vec![0, 1, 2]);
    }

    #[test]
    fn a_huge_update_is_dropped_by_the_norm_filter() {
        // Shared 0, models 2, 3, 4, 100 (all positive): norms 2, 3, 4, 100, median 3.5 -> 4;
        // 100 > 3 * 4 is dropped; one sign cluster. Kept 2, 3, 4, none above 4: mean 3.
        let a = aggregate(
            &[0],
            &inputs_of(&[(&[2], 1), (&[3], 1), (&[4], 1), (&[100], 1)]),
            1,
        );
        assert_eq!(a.weights, vec![3]);
        assert_eq!(a.used, vec![1, 0, 2]);
    }

    #[test]
    fn two_means_ties_keep_the_cluster_of_the_first_model() {
        let labels = majority_cluster(&[[1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0]]);
        assert_eq!(labels, vec![true, false, true, false]);
    }
}

//! `geomed`: the geometric median (the point minimising the sum of Euclidean distances to the
//! models; Pillutla et al., 2022, RFA) by fixed-point Weiszfeld steps (Weiszfeld, 1937) until
//! a step no longer moves the estimate, at most [`MAX_STEPS`].
//!
//! Start: `z` = the coordinate-wise median ([`super::median_of`]). The mean the rule used to
//! start from is dragged by a far model (with models 0, 0.01 and 140000 it sits at 46667), and
//! Weiszfeld needs many steps to walk back from it; the median already lies inside the honest
//! majority's range whenever `q >= 2f + 1`, so the steps only refine it.
//!
//! One step: for each model `d_k = floor(sqrt(sum_i (w_k,i - z_i)^2))`, `d_min` the smallest
//! non-zero `d_k`, `b_k = floor(2^64 d_min / d_k)` (0 for a model on `z`) and
//! `T_i = sum_k b_k w_k,i / sum_k b_k`, exact in `i128` and rounded half away from zero. When
//! no model sits on `z` the step is `T`. When `eta` models sit on `z` (plain Weiszfeld would
//! stay there), Vardi and Zhang's (2000) correction: `r = |T - z| B / (2^64 d_min)`
//! (`B = sum_k b_k`); if `r <= eta`, `z` is the median and the step returns it; otherwise the
//! step is `T` pulled back toward `z` by `eta 2^64 d_min / B` units along `T - z` (the
//! quotients taken with `B >> 32` so that they stay in `u128`). Rescaling by `d_min` keeps every weight in `[1, 2^64]`
//! (so the sums stay below 2^125, as with `2^64 / d_k`) while the nearest model's weight is
//! exactly 2^64: the weights keep 64 significant bits however far the models are, where
//! `floor(2^64 / d_k)` kept only `64 - log2(d_k)` (7.8 % of the spread from exact Weiszfeld
//! on ordinary cases).
//!
//! Stop: when a step returns the `z` it started from (an integer fixed point: the exact step
//! from there is below half a unit in every coordinate), or after [`MAX_STEPS`] steps. The
//! bound is fixed, so the cost is too: at most `MAX_STEPS * q * len` multiply-adds.
//! Sample counts are ignored; defined for `q >= 2f + 1`.
//!
//! Used: the `q - f` submissions nearest the result in L1 (nearest first, ties to the earlier
//! submission).

use super::{
    coordinatewise, isqrt, median_of, models_of, nearest, squared_distance, Aggregate, Input,
};
use crate::contract::payout::div_round_half_away;

/// The most Weiszfeld steps one aggregation takes (it stops earlier at a fixed point). From
/// the median start, the 64 random rounds of the unit tests (outliers up to the int48 limit)
/// reach their fixed point in 1 to 174 steps, most in under 50; a round that has not by then
/// keeps the last estimate.
pub const MAX_STEPS: usize = 256;

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Geomed;

impl super::AggregationRule for Geomed {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// The geometric median: Weiszfeld steps from the coordinate-wise median to a fixed point.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let models = models_of(inputs);
    let z = weiszfeld(&models, MAX_STEPS).0;
    let used = nearest(inputs, &z, inputs.len().saturating_sub(f).max(1));
    Aggregate { weights: z, used }
}

/// The estimate after at most `max_steps` steps from the coordinate-wise median, and the
/// number of steps taken (a step that returns its start counts).
pub fn weiszfeld(models: &[&[i64]], max_steps: usize) -> (Vec<i64>, usize) {
    let mut z = coordinatewise(models, median_of);
    for step in 1..=max_steps {
        let next = step_from(models, &z);
        if next == z {
            return (z, step);
        }
        z = next;
    }
    (z, max_steps)
}

/// One fixed-point Weiszfeld step from `z`, with Vardi and Zhang's (2000) correction when `z`
/// sits on models (plain Weiszfeld would stay there: the 1-unit floor gives such a model a
/// weight `d_min` times the others').
fn step_from(models: &[&[i64]], z: &[i64]) -> Vec<i64> {
    let squared: Vec<u128> = models.iter().map(|w| squared_distance(w, z)).collect();
    // eta models coincide with z; the step averages the others.
    let eta = squared.iter().filter(|&&d| d == 0).count();
    if eta == models.len() {
        return z.to_vec();
    }
    let d: Vec<u128> = squared.iter().map(|&s| isqrt(s)).collect();
    let d_min = *d.iter().filter(|&&dk| dk > 0).min().expect("a model off z");
    // d_min <= d_k < 2^57, so 2^64 d_min < 2^121 and each weight lies in [1, 2^64].
    let b: Vec<i128> = d
        .iter()
        .map(|&dk| {
            (d_min << 64)
                .checked_div(dk)
                .map_or(0, |w| i128::try_from(w).expect("at most 2^64"))
        })
        .collect();
    let total: i128 = b.iter().sum();
    let t: Vec<i64> = (0..z.len())
        .map(|i| {
            let num: i128 = models
                .iter()
                .zip(&b)
                .map(|(w, &bk)| bk * i128::from(w[i]))
                .sum();
            i64::try_from(div_round_half_away(num, total)).expect("a weighted mean of i64")
        })
        .collect();
    if eta == 0 {
        return t;
    }
    // Vardi-Zhang: with R = sum_{k off z} (w_k - z) / d_k and r = |R|, z is the median when
    // r <= eta; otherwise the step is T - eta R / (r |R| / r) ... = T - (T - z) eta / r. Here
    // R = (T - z) B / (2^64 d_min) with B = sum b_k, so r = |T - z| B / (2^64 d_min) and the
    // step pulls T back toward z by the length s = eta 2^64 d_min / B along T - z.
    // Computed with B >> 32 to stay in u128: |T - z| < 2^58, B >> 32 < 2^47.
    let diff: Vec<i128> = t
        .iter()
        .zip(z)
        .map(|(&a, &c)| i128::from(a) - i128::from(c))
        .collect();
    let norm = isqrt(diff.iter().map(|&x| x.unsigned_abs().pow(2)).sum());
    let b_hi = (total as u128 >> 32).max(1);
    let eta = eta as u128;
    if norm * b_hi <= (eta * d_min) << 32 {
        return z.to_vec(); // r <= eta: z is the geometric median
    }
    let s = i128::try_from(((eta * d_min) << 32) / b_hi).expect("below 2^104");
    let norm = i128::try_from(norm).expect("below 2^58");
    t.iter()
        .zip(&diff)
        .map(|(&ti, &x)| {
            i64::try_from(i128::from(ti) - div_round_half_away(x * s, norm))
                .expect("between z and T")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn a_far_outlier_does_not_drag_it() {
        // Issue #33: q = 3, f = 1, scalar models 0, 0.01, 140000 (scale 1e9). The geometric
        // median of three points on a line is the middle one, 0.01 = 10^7 units; the old rule
        // (mean start, 8 steps, 2^64 / d_k) returned 272.90.
        let scale = 1_000_000_000i64;
        let a = aggregate(
            &inputs_of(&[(&[0], 1), (&[scale / 100], 1), (&[140_000 * scale], 1)]),
            1,
        );
        assert_eq!(a.weights, vec![scale / 100]);
        assert_eq!(a.used, vec![1, 0]);
    }

    #[test]
    fn moves_from_the_median_to_the_cluster() {
        // Median of 0, 0, 0, 10 = 0, where three models sit (eta = 3) and the fourth is 10
        // away: T = 10, r = |T - z| B / (2^64 d_min) = 10 * 2^64 / (10 * 2^64) = 1 <= 3: z = 0
        // is the geometric median, a fixed point.
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

    #[test]
    fn a_step_from_off_center_rescales_by_the_nearest() {
        // Models 0, 4, 100 from z = 3 (not the median, to test one step): distances 3, 1, 97,
        // d_min = 1, weights floor(2^64 / 3), 2^64, floor(2^64 / 97):
        // z = (4 + 100 / 97) / (1 / 3 + 1 + 1 / 97) = 5.0309 / 1.3436 = 3.744 -> 4.
        let models: [&[i64]; 3] = [&[0], &[4], &[100]];
        assert_eq!(step_from(&models, &[3]), vec![4]);
        // From z = 4, on a model (eta = 1): T = 100 / 96 / (1 / 4 + 1 / 96) = 4.0 -> 4... the
        // others are 0 (4 away) and 100 (96 away): T = (0 / 4 + 100 / 96) / (1 / 4 + 1 / 96)
        // = 4, r = |T - z| ... = 0 <= 1: 4 is the median of 0, 4, 100.
        assert_eq!(step_from(&models, &[4]), vec![4]);
        // 2-D, a point on a model that is not the median: models (0, 0), (10, 0), (10, 1),
        // (10, -1) from z = (0, 0): T = (10, 0) (weights about equal), r = 10 * B / (2^64
        // d_min) = 10 (1 + 2 * 10 / sqrt(101)) / 10 = 2.99 > 1: the step leaves (0, 0) toward
        // T, pulled back by 2^64 d_min / B = 10 / 2.99 = 3.34: (6.66, 0); in integers
        // d = 0, 10, floor(sqrt(101)) = 10, 10 and the pull floor(10 / 3) = 3: (7, 0).
        let models: [&[i64]; 4] = [&[0, 0], &[10, 0], &[10, 1], &[10, -1]];
        assert_eq!(step_from(&models, &[0, 0]), vec![7, 0]);
    }

    /// Exact Weiszfeld in f64 from the mean (which, unlike the median, is almost surely on no
    /// model, so plain Weiszfeld converges), run far past convergence.
    fn weiszfeld_f64(models: &[Vec<i64>]) -> Vec<f64> {
        let len = models[0].len();
        let mut z: Vec<f64> = (0..len)
            .map(|i| models.iter().map(|w| w[i] as f64).sum::<f64>() / models.len() as f64)
            .collect();
        for _ in 0..20_000 {
            let b: Vec<f64> = models
                .iter()
                .map(|w| {
                    let s: f64 = w
                        .iter()
                        .zip(&z)
                        .map(|(&x, &c)| (x as f64 - c) * (x as f64 - c))
                        .sum();
                    1.0 / s.sqrt().max(1e-9)
                })
                .collect();
            let total: f64 = b.iter().sum();
            z = (0..len)
                .map(|i| {
                    models
                        .iter()
                        .zip(&b)
                        .map(|(w, &bk)| bk * w[i] as f64)
                        .sum::<f64>()
                        / total
                })
                .collect();
        }
        z
    }

    #[test]
    fn random_rounds_land_near_exact_weiszfeld() {
        // 64 rounds: 5..=11 models, up to (q - 1) / 2 of them outliers anywhere up to the int48
        // limit, the others spread +-10^6 units around a random center. The integer estimate
        // must reach its fixed point before MAX_STEPS and lie within 10^-4 of the honest
        // spread (100 units) of the f64 geometric median in every coordinate (measured: at most
        // 8 units). The old rule (mean start, 8 steps) missed by up to 1100x the spread.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let limit = (1i64 << 47) - 1;
        for case in 0..64 {
            let q = 5 + (next() % 7) as usize;
            let outliers = (next() % ((q as u64 - 1) / 2 + 1)) as usize;
            let len = 1 + (next() % 4) as usize;
            let spread = 1_000_000i64;
            let center: Vec<i64> = (0..len)
                .map(|_| (next() % 2_000_000_000) as i64 - 1_000_000_000)
                .collect();
            let models: Vec<Vec<i64>> = (0..q)
                .map(|k| {
                    center
                        .iter()
                        .map(|&c| {
                            if k < outliers {
                                let far = (next() % (limit as u64)) as i64;
                                if next() % 2 == 0 {
                                    far
                                } else {
                                    -far
                                }
                            } else {
                                c + (next() % (2 * spread as u64)) as i64 - spread
                            }
                        })
                        .collect()
                })
                .collect();
            let refs: Vec<&[i64]> = models.iter().map(|w| &w[..]).collect();
            let (z, steps) = weiszfeld(&refs, MAX_STEPS);
            assert!(
                steps < MAX_STEPS,
                "case {case}: no fixed point in {steps} steps"
            );
            let exact = weiszfeld_f64(&models);
            let cost = |p: &[f64]| -> f64 {
                models
                    .iter()
                    .map(|w| {
                        w.iter()
                            .zip(p)
                            .map(|(&x, &c)| (x as f64 - c).powi(2))
                            .sum::<f64>()
                            .sqrt()
                    })
                    .sum()
            };
            let zf: Vec<f64> = z.iter().map(|&v| v as f64).collect();
            // Every minimiser costs the same; ours may cost a few units more.
            assert!(
                cost(&zf) <= cost(&exact) + 1e-4 * spread as f64,
                "case {case}: cost {} vs exact {}",
                cost(&zf),
                cost(&exact)
            );
            if len == 1 && q.is_multiple_of(2) {
                continue; // on a line with an even count the minimisers form an interval
            }
            for (i, (&zi, &ei)) in z.iter().zip(&exact).enumerate() {
                let err = (zi as f64 - ei).abs();
                assert!(
                    err <= 1e-4 * spread as f64,
                    "case {case}, weight {i}: {zi} vs exact {ei} (q {q}, {outliers} outliers)"
                );
            }
        }
    }
}

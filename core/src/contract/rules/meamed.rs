//! `meamed`: the mean around the median (Xie, Koyejo and Gupta, 2018, "Generalized
//! Byzantine-tolerant SGD", arXiv:1802.10116; ByzFL's `Meamed`). For each weight: the median
//! `m` of the `q` values ([`super::median_of`], the rounded mean of the two middle values for
//! an even `q`), then the mean of the `q - f` values closest to `m`, rounded half away from
//! zero ([`mean_around_median`]). Defined for `q >= 2f + 1`; sample counts are ignored.
//!
//! Ties in `|v - m|` go to the smaller value (a value below the median before one the same
//! distance above it), which makes the choice a function of the multiset of values alone.
//! ByzFL's `argpartition` leaves such ties unspecified.
//!
//! Used: the `q - f` submissions nearest the result in L1 (nearest first, ties to the earlier
//! submission).

use super::{coordinatewise, median_of, models_of, nearest, Aggregate, Input};
use crate::contract::payout::div_round_half_away;

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Meamed;

impl super::AggregationRule for Meamed {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// The coordinate-wise mean of the `q - f` values around the median.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let q = inputs.len();
    let keep = q.saturating_sub(f).max(1);
    let weights = coordinatewise(&models_of(inputs), |column| {
        mean_around_median(column, keep)
    });
    let used = nearest(inputs, &weights, keep);
    Aggregate { weights, used }
}

/// The mean of the `keep` (`1..=values.len()`) values closest to the median of `values`
/// (reordered in place), ties in distance to the smaller value, rounded half away from zero.
/// Shared with `bulyan`'s second step.
pub fn mean_around_median(values: &mut [i64], keep: usize) -> i64 {
    assert!(
        (1..=values.len()).contains(&keep),
        "keep 1..=n values around the median"
    );
    let m = i128::from(median_of(values));
    // `median_of` sorted the values; the `keep` closest form a contiguous window of the
    // sorted order. Grow it from empty by taking, at each step, the nearer of the next value
    // below and the next above (below on ties).
    let n = values.len();
    let start = values.partition_point(|&v| i128::from(v) < m);
    let (mut lo, mut hi) = (start, start); // the window is values[lo..hi]
    while hi - lo < keep {
        let below = (lo > 0).then(|| m - i128::from(values[lo - 1]));
        let above = (hi < n).then(|| i128::from(values[hi]) - m);
        match (below, above) {
            (Some(b), Some(a)) if b <= a => lo -= 1,
            (Some(_), None) => lo -= 1,
            _ => hi += 1,
        }
    }
    let sum: i128 = values[lo..hi].iter().map(|&v| i128::from(v)).sum();
    i64::try_from(div_round_half_away(sum, keep as i128)).expect("a mean of i64")
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn averages_the_values_nearest_the_median() {
        // q = 5, f = 1, keep 4. Column (100, 1, 2, 4, -50): median 2; distances 98, 1, 0, 2,
        // 52 -> 2, 1, 4, -50: (2 + 1 + 4 - 50) / 4 = -10.75 -> -11.
        // Column (0, 0, 1, 1, 9): median 1; distances 1, 1, 0, 0, 8 -> 1, 1, 0, 0: 0.5 -> 1.
        let a = aggregate(
            &inputs_of(&[
                (&[100, 0], 1),
                (&[1, 0], 1),
                (&[2, 1], 1),
                (&[4, 1], 1),
                (&[-50, 9], 1),
            ]),
            1,
        );
        assert_eq!(a.weights, vec![-11, 1]);
        // L1 to (-11, 1): 112, 13, 13, 15, 47 -> 1, 2, 3, 4.
        assert_eq!(a.used, vec![1, 2, 3, 4]);
    }

    #[test]
    fn distance_ties_take_the_smaller_value() {
        // Median of (1, 3, 5) is 3; keep 2: 3 and then 1 or 5, both 2 away: 1. (3 + 1) / 2.
        assert_eq!(mean_around_median(&mut [5, 3, 1], 2), 2);
        // Even count: (0, 2, 4, 10), median 3; keep 2: 2 and 4 (both 1 away) -> 3.
        assert_eq!(mean_around_median(&mut [10, 4, 2, 0], 2), 3);
        // keep 3: then 0 (3 away) before 10 (7 away): (0 + 2 + 4) / 3 = 2.
        assert_eq!(mean_around_median(&mut [10, 4, 2, 0], 3), 2);
        // keep all is the mean.
        assert_eq!(mean_around_median(&mut [10, 4, 2, 0], 4), 4);
    }

    #[test]
    fn f_zero_is_the_plain_mean() {
        let a = aggregate(&inputs_of(&[(&[1], 1), (&[2], 9), (&[9], 1)]), 0);
        assert_eq!(a.weights, vec![4]);
    }
}

//! `trimmed-mean` (Yin et al., 2018): for each weight, sort the `q` values, drop the `f`
//! smallest and the `f` largest, and average the `q - 2f` left, rounded half away from zero.
//! Needs `q >= 2f + 1`; sample counts are ignored.
//!
//! Used: the `q - f` submissions nearest the aggregate in L1 (nearest first, ties to the
//! earlier submission).

use super::{coordinatewise, models_of, nearest, Aggregate, Input};
use crate::contract::payout::div_round_half_away;

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct TrimmedMean;

impl super::AggregationRule for TrimmedMean {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// The coordinate-wise `f`-trimmed mean.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let q = inputs.len();
    let kept = q - 2 * f;
    let weights = coordinatewise(&models_of(inputs), |column| {
        column.sort_unstable();
        let sum: i128 = column[f..q - f].iter().map(|&w| i128::from(w)).sum();
        i64::try_from(div_round_half_away(sum, kept as i128)).expect("a mean of i64")
    });
    let used = nearest(inputs, &weights, q.saturating_sub(f).max(1));
    Aggregate { weights, used }
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn drops_f_from_each_end_then_averages() {
        // f = 1, column (100, 1, 2, 4, -50): sorted -50, 1, 2, 4, 100 -> mean(1, 2, 4) = 7/3
        // -> 2; column (0, 0, 1, 1, 1): -> mean(0, 1, 1) = 2/3 -> 1.
        let a = aggregate(
            &inputs_of(&[
                (&[100, 0], 1),
                (&[1, 0], 1),
                (&[2, 1], 1),
                (&[4, 1], 1),
                (&[-50, 1], 1),
            ]),
            1,
        );
        assert_eq!(a.weights, vec![2, 1]);
        // L1 to (2, 1): 99, 2, 0, 2, 52 -> 2, 1, 3, 4.
        assert_eq!(a.used, vec![2, 1, 3, 4]);
    }

    #[test]
    fn f_zero_is_the_plain_mean() {
        let a = aggregate(&inputs_of(&[(&[1], 1), (&[2], 9)]), 0);
        assert_eq!(a.weights, vec![2]); // 1.5 -> 2
    }
}

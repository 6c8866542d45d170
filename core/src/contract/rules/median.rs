//! `median`: the coordinate-wise median (Yin et al., 2018). For each weight, the middle value
//! of the `q` submitted values; for even `q` the mean of the two middle values rounded half away
//! from zero ([`super::median_of`]). Defined for `q >= 2f + 1`; sample counts are ignored.
//!
//! Used: the `q - f` submissions nearest the median in L1 (nearest first, ties to the earlier
//! submission).

use super::{coordinatewise, median_of, models_of, nearest, Aggregate, Input};

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Median;

impl super::AggregationRule for Median {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// The coordinate-wise median.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let weights = coordinatewise(&models_of(inputs), median_of);
    let used = nearest(inputs, &weights, inputs.len().saturating_sub(f).max(1));
    Aggregate { weights, used }
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn coordinate_wise_middle_values() {
        // Columns (1, 9, 2) -> 2 and (-5, 0, 100) -> 0; L1 to (2, 0): 6, 7, 100.
        let a = aggregate(
            &inputs_of(&[(&[1, -5], 1), (&[9, 0], 1), (&[2, 100], 4_000_000_000)]),
            1,
        );
        assert_eq!(a.weights, vec![2, 0]);
        assert_eq!(a.used, vec![0, 1]);
    }

    #[test]
    fn even_count_takes_the_rounded_middle_mean() {
        // Columns (1, 2, 3, 10) -> 2.5 -> 3; (-1, -2, -3, -10) -> -2.5 -> -3.
        let a = aggregate(
            &inputs_of(&[(&[1, -1], 1), (&[2, -2], 1), (&[3, -3], 1), (&[10, -10], 1)]),
            1,
        );
        assert_eq!(a.weights, vec![3, -3]);
        // L1 to (3, -3): 4, 2, 0, 14 -> 2, 1, 0.
        assert_eq!(a.used, vec![2, 1, 0]);
    }
}

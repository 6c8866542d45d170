//! `multi-krum` (Blanchard et al., 2017): Krum scores as in `krum` (`m = q - f - 2` nearest,
//! squared Euclidean, exact), then the `q - f` models with the smallest scores (ties: the
//! earlier submission) are averaged without weights, rounded half away from zero. Needs
//! `q >= 2f + 3`. Sample counts are ignored.
//!
//! Used: the `q - f` selected models, best score first.

use super::{krum_scores, mean, models_of, Aggregate, Input};

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct MultiKrum;

impl super::AggregationRule for MultiKrum {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// The mean of the `q - f` best-scored models.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let models = models_of(inputs);
    let m = models.len().saturating_sub(f + 2).max(1);
    let scores = krum_scores(&models, m);
    let mut order: Vec<usize> = (0..models.len()).collect();
    order.sort_by_key(|&i| (scores[i], i));
    order.truncate(models.len().saturating_sub(f).max(1));
    let chosen: Vec<&[i64]> = order.iter().map(|&i| models[i]).collect();
    Aggregate {
        weights: mean(&chosen),
        used: order,
    }
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn averages_the_best_scored_models() {
        // Scores as in krum's test: 10, 5, 13, 50, 65 -> order 1, 0, 2, 3 (q - f = 4).
        // Mean of 1, 0, 3, 10 = 3.5 -> 4.
        let a = aggregate(
            &inputs_of(&[(&[0], 1), (&[1], 1), (&[3], 1), (&[10], 1), (&[11], 1)]),
            1,
        );
        assert_eq!(a.weights, vec![4]);
        assert_eq!(a.used, vec![1, 0, 2, 3]);
    }
}

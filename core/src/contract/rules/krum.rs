//! `krum` (Blanchard et al., 2017): with `q` models and `f` assumed Byzantine, each model's
//! score is the sum of its squared Euclidean distances to its `m = q - f - 2` nearest other
//! models (exact in `u128`); the model with the smallest score (ties: the earlier submission)
//! becomes the shared model, exactly. Needs `q >= 2f + 3`. Sample counts are ignored.
//!
//! The neighbour count follows Blanchard et al. (their Krum sums over the `n - f - 2` closest
//! vectors). ByzFL's `Krum(f)` (and its `MultiKrum`) sums over `n - f - 1` (it drops the zero
//! self-distance from each sorted row and keeps the next `n - f - 1`), so on the same vectors
//! the two can pick different models; `multi-krum` here uses the same `n - f - 2` as Krum.
//! `tests/byzfl.rs` checks [`super::krum_scores`] with ByzFL's count against ByzFL's choice.
//!
//! Used: the selected model, then the `m` models its score summed over (nearest first, ties to
//! the earlier submission): they vouched for it. The other `f + 1` lose their stakes.

use super::{krum_scores, models_of, squared_distance, Aggregate, Input};

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Krum;

impl super::AggregationRule for Krum {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.f)
    }
}

/// The Krum choice and its neighbourhood.
pub fn aggregate(inputs: &[Input], f: usize) -> Aggregate {
    let models = models_of(inputs);
    let m = models.len().saturating_sub(f + 2).max(1);
    let scores = krum_scores(&models, m);
    let best = (0..models.len())
        .min_by_key(|&i| (scores[i], i))
        .expect("non-empty");
    let mut others: Vec<(u128, usize)> = (0..models.len())
        .filter(|&j| j != best)
        .map(|j| (squared_distance(models[best], models[j]), j))
        .collect();
    others.sort_unstable();
    let mut used = vec![best];
    used.extend(others.iter().take(m).map(|&(_, j)| j));
    Aggregate {
        weights: models[best].to_vec(),
        used,
    }
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn picks_the_model_in_the_tightest_cluster() {
        // q = 5, f = 1, m = 2. 1-D models 0, 1, 3, 10, 11:
        // scores 0: 1 + 9 = 10; 1: 1 + 4 = 5; 3: 4 + 9 = 13; 10: 1 + 49 = 50; 11: 1 + 64 = 65.
        let a = aggregate(
            &inputs_of(&[
                (&[0], 1),
                (&[1], 1),
                (&[3], 1),
                (&[10], 1),
                (&[11], 1_000_000),
            ]),
            1,
        );
        assert_eq!(a.weights, vec![1]);
        assert_eq!(a.used, vec![1, 0, 2]);
    }

    #[test]
    fn ties_go_to_the_earlier_submission() {
        // Two identical pairs: every score is 0 + d; models 0 and 1 tie with 2 and 3.
        let a = aggregate(
            &inputs_of(&[
                (&[5, 5], 1),
                (&[5, 5], 1),
                (&[7, 7], 1),
                (&[7, 7], 1),
                (&[6, 6], 1),
            ]),
            1,
        );
        assert_eq!(a.weights, vec![5, 5]);
        assert_eq!(a.used, vec![0, 1, 4]);
    }
}

//! `paper`: the paper's contract. Submissions farther than the outlier threshold from the
//! shared model were already rejected on arrival (`contract.outlier_threshold`, see the
//! contract's module doc); the accepted ones are averaged by sample-weighted FedAvg (as
//! `fedavg`), and *all* of them are used, ranked by `|d_k - median(d)|` on their L1 distances
//! ([`crate::contract::payout::rank`]); the reward rule then pays by rank with the paper's
//! +1/-1 weights ([`crate::contract::payout::payouts`]). `f` is ignored: the threshold, not a
//! count, is the defence.
//!
//! The authors' variants (`contract.fedavg_rounding`, `rank_key`, `median`, `rank_ties`;
//! docs/CONTRACT.md) change the FedAvg rounding and the ranking here; the others act on
//! arrival (`threshold`, `int48_products`) and in the payouts (`payout_rounding`, `pool`).
//! `contract.rank_order = "nearest"` (issue #36, beyond the paper) ranks by the distance
//! itself instead of around the median ([`crate::contract::rank_order`]).

use super::{Aggregate, Input};
use crate::config::{ContractOptions, RankKey};
use crate::contract::{payout, rank_order};

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Paper;

impl super::AggregationRule for Paper {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.options)
    }
}

/// FedAvg of the accepted inputs; all used, in the paper's rank order.
pub fn aggregate(inputs: &[Input], options: &ContractOptions) -> Aggregate {
    let models: Vec<(&[i64], u64)> = inputs.iter().map(|s| (s.weights, s.samples)).collect();
    let n = inputs[0].weights.len() as u64;
    let keys: Vec<u64> = inputs
        .iter()
        .map(|s| match options.rank_key {
            RankKey::Distance => s.distance_units,
            // The authors rank on the truncated mean absolute error, which creates ties.
            RankKey::Mae => s.distance_units / n,
        })
        .collect();
    Aggregate {
        weights: payout::fedavg(&models, options.fedavg_rounding),
        used: rank_order::rank(options.rank_order, &keys, options.median, options.rank_ties),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fedavg_and_rank_by_distance_to_the_median_distance() {
        let models: [&[i64]; 3] = [&[0], &[6], &[3]];
        let inputs: Vec<Input> = models
            .iter()
            .zip([(1, 50u64), (2, 10), (1, 30)])
            .map(|(w, (n, d))| Input {
                weights: w,
                samples: n,
                distance_units: d,
            })
            .collect();
        let a = aggregate(&inputs, &ContractOptions::default());
        // (0 + 12 + 3) / 4 = 3.75 -> 4; median distance 30: keys 20, 20, 0.
        assert_eq!(a.weights, vec![4]);
        assert_eq!(a.used, vec![2, 0, 1]);
    }
}

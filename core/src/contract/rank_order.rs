//! `contract.rank_order`: which accepted submission the paper's ranking puts first (beyond the
//! paper; issue #36, the counterfactual of REPRODUCTION.md's claim 12).
//!
//! - `median` (the paper's, the default): closest to the median distance first, the key
//!   `|d_k - median(d)|` ([`payout::rank`]). A submission's rank depends on where the *other*
//!   submissions' distances put the median: a lone model far from the honest cluster ranks
//!   last, a group of alike models that holds the median ranks first.
//! - `nearest`: closest to the shared model first, the key `d_k` itself, ascending. A
//!   submission's rank depends only on how its distance compares with each other one, so the
//!   number of alike models in the round no longer moves the centre the ranking measures from.
//!
//! `d_k` is the contract's ranking key (`contract.rank_key`: the L1 distance or the authors'
//! truncated mean absolute error); ties are ordered by `contract.rank_ties` in both orders.
//! Only the native engine has `nearest` (`contracts/SwarmFL.sol` ranks around the median;
//! validation refuses `engine = evm` with it).

use super::payout;
use crate::config::{MedianRule, RankOrder, RankTies};

/// Indices of `keys` (in submission order), best first, under `order`; `keys` is non-empty.
pub fn rank(order: RankOrder, keys: &[u64], median: MedianRule, ties: RankTies) -> Vec<usize> {
    match order {
        RankOrder::Median => payout::rank(keys, median, ties),
        RankOrder::Nearest => {
            assert!(!keys.is_empty(), "ranking of no models");
            payout::order_by(keys, ties)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(order: RankOrder, keys: &[u64], expect: &[usize]) {
        assert_eq!(
            rank(order, keys, MedianRule::Lower, RankTies::Stable),
            expect,
            "{order:?} {keys:?}"
        );
    }

    #[test]
    fn median_order_is_the_papers_ranking() {
        // Median 40: keys 30, 20, 10, 0, 10, 110, 150.
        check(
            RankOrder::Median,
            &[10, 20, 30, 40, 50, 150, 190],
            &[3, 2, 4, 1, 0, 5, 6],
        );
    }

    #[test]
    fn nearest_order_puts_the_smallest_distance_first() {
        check(
            RankOrder::Nearest,
            &[10, 20, 30, 40, 50, 150, 190],
            &[0, 1, 2, 3, 4, 5, 6],
        );
        check(RankOrder::Nearest, &[50, 5, 30], &[1, 2, 0]);
        // Ties keep submission order.
        check(RankOrder::Nearest, &[7, 3, 7, 3], &[1, 3, 0, 2]);
    }

    #[test]
    fn a_lone_model_below_the_cluster_ranks_last_around_the_median_and_first_nearest() {
        // Six honest distances 100..=105 and one extrapolated model at 40.
        let keys = [100, 101, 40, 102, 103, 104, 105];
        // Median 102: keys 2, 1, 62, 0, 1, 2, 3; the model at 40 is last.
        check(RankOrder::Median, &keys, &[3, 1, 4, 0, 5, 6, 2]);
        check(RankOrder::Nearest, &keys, &[2, 0, 1, 3, 4, 5, 6]);
        // Four alike models at 40..=43 hold the median (43): they rank first around it.
        let keys = [100, 40, 41, 101, 42, 43, 102];
        check(RankOrder::Median, &keys, &[5, 4, 2, 1, 0, 3, 6]);
    }

    #[test]
    fn nearest_order_with_quicksort_ties_is_a_permutation_sorted_by_key() {
        let keys = [9, 2, 9, 2, 5];
        let order = rank(
            RankOrder::Nearest,
            &keys,
            MedianRule::Lower,
            RankTies::Quicksort,
        );
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, [0, 1, 2, 3, 4]);
        let ranked: Vec<u64> = order.iter().map(|&i| keys[i]).collect();
        assert_eq!(ranked, [2, 2, 5, 9, 9]);
    }
}

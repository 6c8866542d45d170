//! Aggregation rules: how a round's accepted submissions become the next shared model, and
//! which of them the rule *used* (the reward rule pays exactly those).
//!
//! One file per rule, declared and dispatched by its line in the [`Rule`] registry
//! (`config/contract.rs`: `Krum = "krum" in krum => ..`, its name, file and quorum): the line
//! makes `declare_rules!` (below) write `pub mod krum;` and the arm that calls `krum::Krum`'s
//! [`AggregationRule`]. A new rule is that file and that line; `core/tests/registry.rs` fails
//! on a file here that the registry does not list. Every rule is integer arithmetic on fixed-point
//! weights (`|w_i| < 2^47`, at most 2^16 weights, at most 10 000 submissions), deterministic,
//! with every rounding and tie stated in its file. Shared conventions:
//!
//! - Submissions are indexed in submission (chain) order; every tie is broken by the lower
//!   index, so the earlier submission wins.
//! - Means round to the nearest integer, ties away from zero
//!   ([`crate::contract::payout::div_round_half_away`]).
//! - Squared distances are exact in `u128`; Euclidean norms are `floor(sqrt(.))` of those
//!   ([`isqrt`]).
//! - The robust rules ignore claimed sample counts: a claim is unverifiable input (one robot
//!   claiming 2^32 samples would otherwise own FedAvg). `fedavg` and `paper` weight by them.
//! - `f` is `contract.assumed_f`, the number of Byzantine submissions per round the rule is
//!   built to withstand; [`Rule::min_quorum`] is the smallest quorum for which the rule is
//!   defined with that `f`.
//! - Rules that produce an aggregate without selecting models (median, trimmed mean, geometric
//!   median, centered clipping, meamed) *use* the `q - f` submissions nearest (L1) to their aggregate
//!   ([`nearest`]): the `f` farthest are the ones the rule treats as suspect.

use super::payout::{self, div_round_half_away};
use crate::config::{ContractOptions, Rule};

/// Writes `pub mod file;` for each line of the [`Rule`] registry and `Rule::implementation`,
/// the `match` from each variant to the type of its name in its file (`krum::Krum`). Every
/// rule's line names its file: a line without one does not compile.
macro_rules! declare_rules {
    (Rule: $( $Variant:ident in $file:ident ),+) => {
        $( pub mod $file; )+

        impl Rule {
            /// The rule's arithmetic: the type its registry line names.
            fn implementation(self) -> &'static dyn AggregationRule {
                match self {
                    $( Rule::$Variant => &$file::$Variant, )+
                }
            }
        }
    };
}

crate::config::rule_files!(declare_rules);

/// An aggregation rule: the type of a rule's file (`krum::Krum`) that [`Rule::aggregate`]
/// calls. One call signature for every rule, as ByzFL's aggregators and Flower's strategies
/// have: each rule reads from the [`Round`] what it needs.
pub trait AggregationRule {
    /// The round's aggregate (the preconditions are [`Rule::aggregate`]'s).
    fn aggregate(&self, round: &Round) -> Aggregate;
}

/// A round as a rule reads it (see [`Rule::aggregate`]).
#[derive(Clone, Copy, Debug)]
pub struct Round<'a> {
    /// The shared model the round was opened on.
    pub current: &'a [i64],
    /// The accepted submissions in submission order (non-empty, each of `current`'s length).
    pub inputs: &'a [Input<'a>],
    /// The assumed Byzantine count (`inputs.len() >= min_quorum(f)`).
    pub f: usize,
    /// The authors' variants, which only `fedavg` and `paper` read.
    pub options: &'a ContractOptions,
}

/// One accepted submission as a rule sees it.
#[derive(Clone, Copy, Debug)]
pub struct Input<'a> {
    /// The weights (same length as the shared model).
    pub weights: &'a [i64],
    /// Samples claimed (1..=2^32 - 1).
    pub samples: u64,
    /// `sum_i |w_i - w_a,i|` against the shared model.
    pub distance_units: u64,
}

/// What a rule made of a round.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Aggregate {
    /// The next shared model.
    pub weights: Vec<i64>,
    /// Indices of the inputs the rule used, best first (the payout order), each once.
    pub used: Vec<usize>,
}

impl Rule {
    /// True when the outlier threshold rejects submissions as they arrive (paper only: the
    /// other rules judge a round's models together).
    pub fn uses_threshold(self) -> bool {
        self == Rule::Paper
    }

    /// Aggregates a round: `current` is the shared model the round was opened on, `inputs`
    /// the accepted submissions in submission order (non-empty, each of `current`'s length),
    /// `f` the assumed Byzantine count (`inputs.len() >= min_quorum(f)`), `options` the
    /// authors' variants, which only `fedavg` and `paper` read (validation keeps them at their
    /// defaults under the robust rules).
    pub fn aggregate(
        self,
        current: &[i64],
        inputs: &[Input],
        f: usize,
        options: &ContractOptions,
    ) -> Aggregate {
        assert!(!inputs.is_empty(), "aggregation of no models");
        assert!(
            inputs.iter().all(|s| s.weights.len() == current.len()),
            "models of the round's length"
        );
        assert!(
            inputs.len() >= self.min_quorum(f as u32) as usize,
            "{} needs at least {} models with f = {f}",
            self.name(),
            self.min_quorum(f as u32)
        );
        let round = Round {
            current,
            inputs,
            f,
            options,
        };
        let aggregate = self.implementation().aggregate(&round);
        debug_assert_eq!(aggregate.weights.len(), current.len());
        debug_assert!(aggregate.used.iter().all(|&i| i < inputs.len()));
        aggregate
    }
}

/// `floor(sqrt(x))`, exact for every `u128` (Newton's method on integers).
pub fn isqrt(x: u128) -> u128 {
    if x < 2 {
        return x;
    }
    // Start above the root: 2^ceil(bits / 2).
    let bits = 128 - x.leading_zeros();
    let mut r: u128 = 1 << bits.div_ceil(2);
    loop {
        let next = (r + x / r) / 2;
        if next >= r {
            return r;
        }
        r = next;
    }
}

/// `sum_i (a_i - b_i)^2`, exact: each term is below 2^96 and there are at most 2^16 of them.
pub fn squared_distance(a: &[i64], b: &[i64]) -> u128 {
    assert_eq!(
        a.len(),
        b.len(),
        "distance between models of different lengths"
    );
    a.iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = (i128::from(x) - i128::from(y)).unsigned_abs();
            d * d
        })
        .sum()
}

/// The unweighted mean of `models` (non-empty, one length), coordinate by coordinate, rounded
/// half away from zero.
pub fn mean(models: &[&[i64]]) -> Vec<i64> {
    assert!(!models.is_empty(), "mean of no models");
    let len = models[0].len();
    let count = models.len() as i128;
    (0..len)
        .map(|i| {
            let sum: i128 = models.iter().map(|w| i128::from(w[i])).sum();
            i64::try_from(div_round_half_away(sum, count)).expect("a mean lies within its inputs")
        })
        .collect()
}

/// The submitted weight vectors of `inputs`, in submission order.
pub fn models_of<'a>(inputs: &[Input<'a>]) -> Vec<&'a [i64]> {
    inputs.iter().map(|s| s.weights).collect()
}

/// `reduce` applied to each coordinate's column (one value per model, in `models` order) of
/// `models` (non-empty, one length); the column is scratch that `reduce` may reorder.
pub fn coordinatewise(models: &[&[i64]], mut reduce: impl FnMut(&mut [i64]) -> i64) -> Vec<i64> {
    let len = models[0].len();
    let mut column = vec![0i64; models.len()];
    (0..len)
        .map(|i| {
            for (slot, w) in column.iter_mut().zip(models) {
                *slot = w[i];
            }
            reduce(&mut column)
        })
        .collect()
}

/// The median of `values` (non-empty, sorted in place): the middle value for an odd count, the
/// mean of the two middle values rounded half away from zero for an even count.
pub fn median_of(values: &mut [i64]) -> i64 {
    assert!(!values.is_empty(), "median of nothing");
    values.sort_unstable();
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        let sum = i128::from(values[n / 2 - 1]) + i128::from(values[n / 2]);
        i64::try_from(div_round_half_away(sum, 2)).expect("between two i64")
    }
}

/// The indices of the `keep` inputs nearest to `center` in L1 distance, nearest first, ties to
/// the lower index.
pub fn nearest(inputs: &[Input], center: &[i64], keep: usize) -> Vec<usize> {
    let distances: Vec<u64> = inputs
        .iter()
        .map(|s| payout::distance_units(s.weights, center))
        .collect();
    let mut order: Vec<usize> = (0..inputs.len()).collect();
    order.sort_by_key(|&i| (distances[i], i));
    order.truncate(keep.min(inputs.len()));
    order
}

/// Krum scores: for each input, the sum of its `m` smallest squared distances to the others
/// (`m` is clamped to `1..=len - 1`; a lone input scores 0). Saturating, which no legal input
/// reaches (at most 10 000 terms below 2^112).
pub fn krum_scores(models: &[&[i64]], m: usize) -> Vec<u128> {
    let n = models.len();
    let mut d = vec![vec![0u128; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let v = squared_distance(models[i], models[j]);
            d[i][j] = v;
            d[j][i] = v;
        }
    }
    let m = m.clamp(1, n.saturating_sub(1).max(1));
    (0..n)
        .map(|i| {
            let mut row: Vec<u128> = (0..n).filter(|&j| j != i).map(|j| d[i][j]).collect();
            row.sort_unstable();
            row.iter()
                .take(m)
                .fold(0u128, |acc, &x| acc.saturating_add(x))
        })
        .collect()
}

/// Test inputs: each model with its sample count (distance 0: rules do not read it).
#[cfg(test)]
pub(crate) fn inputs_of<'a>(models: &[(&'a [i64], u64)]) -> Vec<Input<'a>> {
    models
        .iter()
        .map(|&(weights, samples)| Input {
            weights,
            samples,
            distance_units: 0,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isqrt_is_the_floor_of_the_root() {
        for x in 0u128..2000 {
            let r = isqrt(x);
            assert!(r * r <= x && (r + 1) * (r + 1) > x, "x = {x}");
        }
        assert_eq!(isqrt(u128::MAX), u128::from(u64::MAX));
        assert_eq!(isqrt(1 << 100), 1 << 50);
        assert_eq!(isqrt((1 << 100) - 1), (1 << 50) - 1);
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median_of(&mut [5, -1, 3]), 3);
        assert_eq!(median_of(&mut [4, 1, 2, 3]), 3); // (2 + 3) / 2 = 2.5 -> 3
        assert_eq!(median_of(&mut [-4, -1, -2, -3]), -3); // -2.5 -> -3
        assert_eq!(median_of(&mut [7]), 7);
    }

    #[test]
    fn mean_rounds_half_away_from_zero() {
        assert_eq!(mean(&[&[1, -1, 2], &[2, -2, 2]]), vec![2, -2, 2]);
        assert_eq!(mean(&[&[0], &[0], &[1]]), vec![0]);
        assert_eq!(mean(&[&[0], &[1], &[1]]), vec![1]);
    }

    #[test]
    fn nearest_breaks_ties_by_submission_order() {
        let a = [0i64, 0];
        let b = [1i64, 0];
        let c = [0i64, -1];
        let inputs: Vec<Input> = [&a[..], &b, &c]
            .iter()
            .map(|w| Input {
                weights: w,
                samples: 1,
                distance_units: 0,
            })
            .collect();
        assert_eq!(nearest(&inputs, &[0, 0], 3), vec![0, 1, 2]);
        assert_eq!(nearest(&inputs, &[1, -1], 2), vec![1, 2]);
    }

    #[test]
    fn krum_scores_sum_the_m_nearest_squared_distances() {
        let models: [&[i64]; 4] = [&[0], &[1], &[3], &[10]];
        // Squared distances from 0: 1, 9, 100; from 1: 1, 4, 81; from 3: 9, 4, 49;
        // from 10: 100, 81, 49.
        assert_eq!(krum_scores(&models, 2), vec![10, 5, 13, 130]);
        assert_eq!(krum_scores(&models, 1), vec![1, 1, 4, 49]);
    }

    #[test]
    fn names_round_trip() {
        for rule in Rule::ALL {
            assert_eq!(Rule::from_name(rule.name()), Some(rule));
        }
    }
}

//! `fedavg`: the sample-weighted average of every accepted model (the paper's security off).
//!
//! `w_i = sum_k n_k w_k,i / sum_k n_k`, exact in `i128`, rounded half away from zero
//! ([`crate::contract::payout::fedavg`]). Uses every model; there are no stakes, so nobody is
//! paid. Assumes no Byzantine robot (`f` is ignored). `contract.fedavg_rounding = truncate`
//! rounds toward zero instead (the authors' Solidity division).

use super::{Aggregate, Input};
use crate::config::FedAvgRounding;
use crate::contract::payout;

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it.
pub struct Fedavg;

impl super::AggregationRule for Fedavg {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        aggregate(round.inputs, round.options.fedavg_rounding)
    }
}

/// FedAvg of all inputs; all are used, in submission order.
pub fn aggregate(inputs: &[Input], rounding: FedAvgRounding) -> Aggregate {
    let models: Vec<(&[i64], u64)> = inputs.iter().map(|s| (s.weights, s.samples)).collect();
    Aggregate {
        weights: payout::fedavg(&models, rounding),
        used: (0..inputs.len()).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::inputs_of;
    use super::*;

    #[test]
    fn weights_by_claimed_samples() {
        // (1 * 10 + 3 * 20) / 4 = 17.5 -> 18; (1 * -1 + 3 * 0) / 4 = -0.25 -> 0.
        let a = aggregate(
            &inputs_of(&[(&[10, -1], 1), (&[20, 0], 3)]),
            FedAvgRounding::Nearest,
        );
        assert_eq!(a.weights, vec![18, 0]);
        assert_eq!(a.used, vec![0, 1]);
    }
}

//! The line search of the adaptive attacks (`optimal-alie`, `optimal-ipm`): the attack factor
//! that moves the contract's aggregate farthest from the honest mean, found by evaluating the
//! contract's own aggregation (pre-aggregators and rule, [`ContractParams::round_aggregate`])
//! on the round as the robot's node holds it. The search follows ByzFL's
//! `Optimal_ALittleIsEnough` / `Optimal_InnerProductManipulation` (Allouah et al.):
//!
//! - expansion: from `x = START`, propose `x + delta`; while a proposal is better take it and
//!   double `delta`; at the first worse one shrink `delta` by [`RATIO`] and stop;
//! - contraction: propose `best + delta`, take it if better, shrink `delta` by [`RATIO`],
//!   until `byzantine.search_evals` evaluations in all have been made.
//!
//! The objective of a factor `x` is `|A(round with the forged model) - mean(honest)|^2`, exact
//! in integers on the fixed-point models the contract would see. The round (see
//! [`hypothetical_round`]) is the accepted submissions of the current round on the robot's own
//! chain, in chain order, then one copy of the forged model for every coalition member that has
//! not yet submitted this round (every Byzantine robot of the coalition runs the same search on
//! the same view and sends the same model), then honest stand-ins (the honest models seen,
//! cyclically) up to the quorum. Under `paper` a forged model beyond the outlier threshold
//! would be refused, so it scores below every accepted one. Strictly better only: ties keep the
//! earlier (smaller) factor. Deterministic: every step is integer or a fixed sequence of `f64`
//! operations.

use super::View;
use crate::contract::rules::{self, Input};
use crate::contract::{model_digest, payout, preagg, ContractParams, Verdict};
use crate::learn;

/// The first factor evaluated.
pub const START: f64 = 0.0;
/// The first step.
pub const DELTA: f64 = 10.0;
/// How the step shrinks after a worse proposal.
pub const RATIO: f64 = 0.8;

/// The models of the hypothetical round: fixed-point weights with the sender standing for
/// each (the robot itself for forged copies and stand-ins), and where the forged copies go.
pub struct Round {
    /// Accepted submissions on the chain, in chain order: (sender, weights, samples).
    pub onchain: Vec<(u32, Vec<i64>, u64)>,
    /// Forged copies to add.
    pub forged_copies: usize,
    /// Honest stand-ins to add after them, in order.
    pub standins: Vec<Vec<i64>>,
    /// The honest accepted models of the round on the chain, in chain order.
    pub honest: Vec<Vec<i64>>,
    /// Their mean, fixed point: the objective's reference.
    pub honest_mean: Vec<i64>,
}

/// The round as `view`'s node holds it, or `None` while it holds fewer than `need` honest
/// accepted models (or the round is already full).
pub fn hypothetical_round(view: &View, need: usize) -> Option<Round> {
    // Indices into the round's submissions; a model is read as the round reads it (under the
    // buffered protocol, the update rebased on w(t)).
    let accepted: Vec<usize> = (0..view.chain.submissions.len())
        .filter(|&i| view.chain.submissions[i].verdict == Verdict::Accepted)
        .collect();
    let in_coalition = |r: u32| view.coalition.get(r as usize).copied().unwrap_or(false);
    let honest: Vec<Vec<i64>> = accepted
        .iter()
        .filter(|&&i| !in_coalition(view.chain.submissions[i].sender))
        .map(|&i| view.chain.round_model(i).to_vec())
        .collect();
    let quorum = view.params.quorum as usize;
    if honest.len() < need.max(1) || accepted.len() >= quorum {
        return None;
    }
    let pending = (0..view.coalition.len())
        .filter(|&r| view.coalition[r] && !view.chain.has_submitted(r as u32))
        .count()
        .max(1);
    let forged_copies = pending.min(quorum - accepted.len());
    let standins = (0..quorum - accepted.len() - forged_copies)
        .map(|i| honest[i % honest.len()].clone())
        .collect();
    let honest_mean = {
        let refs: Vec<&[i64]> = honest.iter().map(|w| &w[..]).collect();
        rules::mean(&refs)
    };
    Some(Round {
        onchain: accepted
            .iter()
            .map(|&i| {
                let s = &view.chain.submissions[i];
                (s.sender, view.chain.round_model(i).to_vec(), s.samples)
            })
            .collect(),
        forged_copies,
        standins,
        honest,
        honest_mean,
    })
}

/// The objective of one forged model: `None` when the contract would not aggregate it
/// (outside int48, or an outlier under the bound in force, `ContractState::outlier_bound_units`).
pub fn objective(view: &View, round: &Round, forged: &[f32]) -> Option<u128> {
    let params: &ContractParams = view.params;
    let current = &view.chain.weights[..];
    let fixed = learn::to_fixed(forged, view.weight_scale).ok()?;
    let distance = payout::distance_units(&fixed, current);
    if params.threshold_applies() && u128::from(distance) > view.chain.outlier_bound_units(params) {
        return None;
    }
    let samples = u64::from(view.config.claimed_samples);
    let mut models: Vec<(u32, &[i64], u64)> = round
        .onchain
        .iter()
        .map(|(r, w, n)| (*r, &w[..], *n))
        .collect();
    models.extend((0..round.forged_copies).map(|_| (view.robot, &fixed[..], samples)));
    models.extend(round.standins.iter().map(|w| (view.robot, &w[..], samples)));
    let inputs: Vec<Input> = models
        .iter()
        .map(|&(_, w, n)| Input {
            weights: w,
            samples: n,
            distance_units: payout::distance_units(w, current),
        })
        .collect();
    let digests: Vec<(u32, crate::types::Digest)> = models
        .iter()
        .map(|&(r, w, _)| (r, model_digest(w)))
        .collect();
    let seed = preagg::shuffle_seed(view.chain.round, &view.chain.weights_digest, &digests);
    let aggregate = params.round_aggregate(current, &inputs, seed);
    Some(rules::squared_distance(
        &aggregate.weights,
        &round.honest_mean,
    ))
}

/// The factor found by the search, with `evals` evaluations of `score` in all (at least 1).
/// `score(x)` is `None` for a factor the contract would refuse, worse than any `Some`.
pub fn search(evals: u32, mut score: impl FnMut(f64) -> Option<u128>) -> f64 {
    let better = |a: Option<u128>, b: Option<u128>| match (a, b) {
        (Some(a), Some(b)) => a > b,
        (Some(_), None) => true,
        (None, _) => false,
    };
    let mut best_x = START;
    let mut best_y = score(best_x);
    let mut delta = DELTA;
    let mut remaining = evals.max(1) - 1;
    while remaining > 0 {
        let x = best_x + delta;
        let y = score(x);
        remaining -= 1;
        if better(y, best_y) {
            (best_x, best_y) = (x, y);
            delta *= 2.0;
        } else {
            delta *= RATIO;
            break;
        }
    }
    while remaining > 0 {
        let x = best_x + delta;
        let y = score(x);
        remaining -= 1;
        if better(y, best_y) {
            (best_x, best_y) = (x, y);
        }
        delta *= RATIO;
    }
    best_x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expansion_doubles_then_contraction_refines() {
        // A peak at 25: 0, 10 (better), 30 (better: |30 - 25| = 5 < 15), 70 (worse: stop,
        // delta = 40 * 0.8 = 32); contraction from 30: 62 (worse, delta 25.6), 55.6 (worse,
        // 20.48), 50.48, 46.38, 43.1, 40.5, 38.4, 36.7, 35.4 ... all worse than 30 ... until
        // the steps fall below 5 and still lie above 30: the best stays 30.
        let mut seen = Vec::new();
        let x = search(12, |x| {
            seen.push(x);
            Some((1000.0 - (x - 25.0).abs() * 10.0) as u128)
        });
        assert_eq!(seen.len(), 12, "exactly the evaluations asked for");
        assert_eq!(&seen[..4], &[0.0, 10.0, 30.0, 70.0]);
        assert_eq!(x, 30.0);
    }

    #[test]
    fn refused_factors_lose_and_ties_keep_the_smaller() {
        // Everything beyond 5 is refused: 0 (score 1), 10 refused: contraction 0 + 8 refused,
        // 6.4 refused, 5.12 refused, 4.096 accepted with 2 > 1.
        let x = search(6, |x| {
            if x > 5.0 {
                None
            } else {
                Some(1 + u128::from(x > 4.0))
            }
        });
        assert_eq!(x, 10.0 * RATIO * RATIO * RATIO * RATIO);
        // A flat objective keeps the start.
        assert_eq!(search(20, |_| Some(7)), START);
        assert_eq!(search(1, |_| Some(7)), START);
    }
}

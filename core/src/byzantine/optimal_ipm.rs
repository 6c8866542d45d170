//! `optimal-ipm`: inner-product manipulation (Xie et al., 2020) with its factor chosen against
//! the contract the robot's chain runs (ByzFL's `Optimal_InnerProductManipulation`): the model
//! `w_i = w_i(t) - epsilon (mu_i - w_i(t))` of [`super::ipm::forge`], with `epsilon` found by
//! the line search of [`super::line_search`] on the round as the robot's node holds it
//! (pre-aggregators and rule evaluated exactly as the contract will), maximising the
//! aggregate's squared distance from the honest mean. `mu` is the mean of the honest accepted
//! models of the round on its chain.
//!
//! Waits until `byzantine.wait_for_honest` honest accepted models of the round are on its
//! chain. Information: w(t), the round's submissions on its chain, the public contract rules,
//! the coalition. Parameters: `byzantine.search_evals`, `byzantine.wait_for_honest`,
//! `byzantine.claimed_samples`.

use super::line_search::{hypothetical_round, objective, search};
use super::{ipm, submit, Action, Attack, View};
use crate::learn;
use crate::rng::Rng;

/// The `optimal-ipm` agent.
pub struct OptimalIpm;

impl Attack for OptimalIpm {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        let Some(round) = hypothetical_round(view, view.config.wait_for_honest as usize) else {
            return Action::Wait;
        };
        let honest: Vec<Vec<f32>> = round
            .honest
            .iter()
            .map(|w| learn::from_fixed(w, view.weight_scale))
            .collect();
        let shared = view.shared();
        let epsilon = search(view.config.search_evals, |e| {
            objective(view, &round, &ipm::forge(&shared, &honest, e))
        });
        submit(view, ipm::forge(&shared, &honest, epsilon))
    }
}

//! `optimal-alie`: "a little is enough" (Baruch et al., 2019) with its factor chosen against
//! the contract the robot's chain runs (ByzFL's `Optimal_ALittleIsEnough`): the model
//! `w_i = mu_i - z sigma_i` of [`super::alie::forge`], with `z` found by the line search of
//! [`super::line_search`], which evaluates the contract's pre-aggregators and rule on the round
//! as the robot's node holds it and maximises the aggregate's squared distance from the honest
//! mean. Where `alie` needs a `z` tuned to the rule, this one finds it each round, and finds 0
//! (the honest mean, harmless) when the rule cannot be moved.
//!
//! Waits until `max(byzantine.wait_for_honest, 2)` honest accepted models of the round are on
//! its chain. Information: the round's submissions on its chain, the public contract rules,
//! the coalition. Parameters: `byzantine.search_evals`, `byzantine.wait_for_honest`,
//! `byzantine.claimed_samples`.

use super::line_search::{hypothetical_round, objective, search};
use super::{alie, submit, Action, Attack, View};
use crate::learn;
use crate::rng::Rng;

/// The `optimal-alie` agent.
pub struct OptimalAlie;

impl Attack for OptimalAlie {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        let need = (view.config.wait_for_honest as usize).max(2);
        let Some(round) = hypothetical_round(view, need) else {
            return Action::Wait;
        };
        let honest: Vec<Vec<f32>> = round
            .honest
            .iter()
            .map(|w| learn::from_fixed(w, view.weight_scale))
            .collect();
        let z = search(view.config.search_evals, |z| {
            objective(view, &round, &alie::forge(&honest, z))
        });
        submit(view, alie::forge(&honest, z))
    }
}

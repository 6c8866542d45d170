//! `collude`: the Byzantine robots agree on one model and all submit it, so distance-based
//! rules see a tight cluster (identical models score 0 against each other under Krum).
//!
//! The agreed model needs no messages: it is a function of what every colluder reads on its
//! chain. `delta = threshold_fraction * threshold` (the contract's public outlier threshold, a
//! mean absolute distance per weight), and per weight `w_i = w_i(t) - delta` if
//! `w_i(t) - w_i(t-1) >= 0`, else `w_i(t) + delta`: the swarm's last step, reversed and
//! flattened to the largest size the paper's threshold accepts. In round 0 there is no step and
//! the colluders all send w(t). Colluders on chains at different heads may disagree for a
//! while; they agree again once their chains do.
//!
//! Information: w(t), w(t-1), the contract's threshold. Parameters:
//! `byzantine.threshold_fraction`, `byzantine.claimed_samples`.

use super::{inflate_samples, submit, Action, Attack, View};
use crate::rng::Rng;

/// The `collude` agent.
pub struct Collude;

impl Attack for Collude {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        let shared = view.shared();
        let weights = match view.previous() {
            None => shared,
            Some(prev) => {
                let step: Vec<f64> = shared
                    .iter()
                    .zip(&prev)
                    .map(|(&w, &p)| f64::from(w) - f64::from(p))
                    .collect();
                let delta = view.config.threshold_fraction * view.threshold();
                inflate_samples::forge(&shared, &step, delta)
            }
        };
        submit(view, weights)
    }
}

//! `mimic` (Karimireddy et al., 2022): copies an honest model of the current round, weights
//! and claimed sample count, so that one robot's data counts several times and the swarm's
//! model drifts towards that robot's (non-i.i.d.) trajectories. All Byzantine robots copy the
//! same victim: the earliest honest submission of the round on their chain.
//!
//! Waits for `byzantine.wait_for_honest` honest models of the round (copies the first).
//! Information: the round's honest submissions. Parameter: `byzantine.wait_for_honest`.

use super::{Action, Attack, View};
use crate::learn;
use crate::rng::Rng;

/// The `mimic` agent.
pub struct Mimic;

impl Attack for Mimic {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        let honest = view.honest_submissions();
        if honest.len() < (view.config.wait_for_honest as usize).max(1) {
            return Action::Wait;
        }
        let victim = honest[0];
        // Its weights, or under the buffered protocol its update rebased on w(t).
        let model = view.honest_fixed()[0];
        Action::Submit {
            weights: learn::from_fixed(model, view.weight_scale),
            samples: u32::try_from(victim.samples).unwrap_or(u32::MAX),
        }
    }
}

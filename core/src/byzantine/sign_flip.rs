//! `sign-flip`: submits the honest update with its sign flipped. A Byzantine robot does not
//! train, so its estimate of the honest update is the swarm's last step `w(t) - w(t-1)`, read
//! from its own chain. In round 0 there is no step: it sends w(t).
//!
//! Formula: `w_i = w_i(t) - scale * (w_i(t) - w_i(t-1))` in `f64`; scale 1 returns w(t-1)
//! (undoes the step), scale 2 steps as far backwards as the swarm stepped forwards.
//! Information: w(t), w(t-1). Parameters: `byzantine.scale`, `byzantine.claimed_samples`.

use super::{submit, to_f32, Action, Attack, View};
use crate::rng::Rng;

/// The `sign-flip` agent.
pub struct SignFlip;

/// The flipped model.
pub fn forge(shared: &[f32], previous: Option<&[f32]>, scale: f64) -> Vec<f32> {
    match previous {
        None => shared.to_vec(),
        Some(prev) => to_f32(
            &shared
                .iter()
                .zip(prev)
                .map(|(&w, &p)| f64::from(w) - scale * (f64::from(w) - f64::from(p)))
                .collect::<Vec<f64>>(),
        ),
    }
}

impl Attack for SignFlip {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        let previous = view.previous();
        submit(
            view,
            forge(&view.shared(), previous.as_deref(), view.config.scale),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reverses_the_last_step() {
        assert_eq!(forge(&[1.0, -2.0], Some(&[0.5, -1.0]), 2.0), vec![0.0, 0.0]);
        assert_eq!(
            forge(&[1.0, -2.0], Some(&[0.5, -1.0]), 1.0),
            vec![0.5, -1.0]
        );
        assert_eq!(forge(&[1.0], None, 2.0), vec![1.0]);
    }
}

//! `ipm`, inner-product manipulation (Xie et al., 2020): the negated honest mean step,
//! `w_i = w_i(t) - scale * (mu_i - w_i(t))`, `mu` the mean of the current round's honest models
//! on the robot's own chain. Every Byzantine robot sends the same direction, so the aggregate's
//! inner product with the true step shrinks (small scale) or turns negative (large scale).
//!
//! Waits for `byzantine.wait_for_honest` honest models of the round. Information: w(t), the
//! round's honest submissions. Parameters: `byzantine.scale` (epsilon),
//! `byzantine.wait_for_honest`, `byzantine.claimed_samples`.

use super::{await_honest, mean, submit, to_f32, Action, Attack, View};
use crate::rng::Rng;

/// The `ipm` agent.
pub struct Ipm;

/// `w(t) - scale (mu - w(t))`.
pub fn forge(shared: &[f32], honest: &[Vec<f32>], scale: f64) -> Vec<f32> {
    let mu = mean(honest);
    to_f32(
        &shared
            .iter()
            .zip(&mu)
            .map(|(&w, &m)| f64::from(w) - scale * (m - f64::from(w)))
            .collect::<Vec<f64>>(),
    )
}

impl Attack for Ipm {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        match await_honest(view, view.config.wait_for_honest as usize) {
            Some(honest) => submit(view, forge(&view.shared(), &honest, view.config.scale)),
            None => Action::Wait,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negated_mean_step() {
        // mu = (2, 0); steps (1, -1); scale 0.5: w = (1, 1) - 0.5 (1, -1) = (0.5, 1.5).
        let honest = vec![vec![1.0f32, 0.0], vec![3.0, 0.0]];
        assert_eq!(forge(&[1.0, 1.0], &honest, 0.5), vec![0.5, 1.5]);
    }
}

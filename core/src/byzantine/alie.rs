//! `alie`, "a little is enough" (Baruch et al., 2019): per weight, the honest mean moved by
//! `z` honest standard deviations, `w_i = mu_i - z * sigma_i`, where `mu` and `sigma` (the
//! population standard deviation) are over the honest models of the current round already on
//! the robot's own chain. Small enough to hide among honest models, consistent enough (every
//! Byzantine robot moves the same way) to bias coordinate-wise and distance-based rules.
//!
//! Waits until `max(byzantine.wait_for_honest, 2)` honest models of the round are on its
//! chain. Information: the round's honest submissions. Parameters: `byzantine.alie_z`,
//! `byzantine.wait_for_honest`, `byzantine.claimed_samples`.

use super::{await_honest, mean, std_dev, submit, to_f32, Action, Attack, View};
use crate::rng::Rng;

/// The `alie` agent.
pub struct Alie;

/// `mu - z sigma` of `honest` (at least one model).
pub fn forge(honest: &[Vec<f32>], z: f64) -> Vec<f32> {
    let mu = mean(honest);
    let sigma = std_dev(honest, &mu);
    to_f32(
        &mu.iter()
            .zip(&sigma)
            .map(|(&m, &s)| m - z * s)
            .collect::<Vec<f64>>(),
    )
}

impl Attack for Alie {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        let need = (view.config.wait_for_honest as usize).max(2);
        match await_honest(view, need) {
            Some(honest) => submit(view, forge(&honest, view.config.alie_z)),
            None => Action::Wait,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_minus_z_deviations() {
        // Weight 0: 1, 3 -> mu 2, sigma 1; weight 1: 0, 0 -> mu 0, sigma 0.
        let honest = vec![vec![1.0f32, 0.0], vec![3.0, 0.0]];
        assert_eq!(forge(&honest, 1.5), vec![0.5, 0.0]);
    }
}

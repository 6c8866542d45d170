//! `inflate-samples`: a model just inside the paper's outlier threshold, pushed against the
//! honest direction, claiming a huge sample count. The contract trusts claimed counts: under
//! sample-weighted FedAvg one accepted model claiming 2^32 - 1 samples against honest claims
//! of a few hundred *is* the aggregate.
//!
//! Formula: `delta = threshold_fraction * threshold` (the threshold is the contract's public
//! `outlier_threshold`, a mean absolute distance per weight), and per weight
//! `w_i = w_i(t) - delta` if `d_i >= 0`, `w_i(t) + delta` if `d_i < 0`, where `d = mu - w(t)`
//! is the mean honest step of the round (the round's honest models on the robot's chain). Its
//! mean absolute distance to w(t) is `delta`, inside the threshold when `threshold_fraction <
//! 1` (0.99 by default leaves room for the float-to-fixed rounding). Claims
//! `byzantine.inflated_samples` (default 2^32 - 1, the contract's limit).
//!
//! Waits for `byzantine.wait_for_honest` honest models; on its last chance with fewer, it uses
//! the last step `d = w(t) - w(t-1)` instead (and skips the phase in round 0). Information:
//! w(t), w(t-1), the round's honest submissions, the contract's threshold. Parameters:
//! `byzantine.threshold_fraction`, `byzantine.inflated_samples`, `byzantine.wait_for_honest`.

use super::{await_honest, mean, to_f32, Action, Attack, View};
use crate::rng::Rng;

/// The `inflate-samples` agent.
pub struct InflateSamples;

/// `w(t)` moved by `delta` against the sign of `direction` on every weight.
pub fn forge(shared: &[f32], direction: &[f64], delta: f64) -> Vec<f32> {
    to_f32(
        &shared
            .iter()
            .zip(direction)
            .map(|(&w, &d)| {
                if d >= 0.0 {
                    f64::from(w) - delta
                } else {
                    f64::from(w) + delta
                }
            })
            .collect::<Vec<f64>>(),
    )
}

impl Attack for InflateSamples {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        let shared = view.shared();
        let direction: Vec<f64> = match await_honest(view, view.config.wait_for_honest as usize) {
            Some(honest) => mean(&honest)
                .iter()
                .zip(&shared)
                .map(|(&m, &w)| m - f64::from(w))
                .collect(),
            None if view.last_chance => match view.previous() {
                Some(prev) => shared
                    .iter()
                    .zip(&prev)
                    .map(|(&w, &p)| f64::from(w) - f64::from(p))
                    .collect(),
                None => return Action::Wait,
            },
            None => return Action::Wait,
        };
        let delta = view.config.threshold_fraction * view.threshold();
        Action::Submit {
            weights: forge(&shared, &direction, delta),
            samples: view.config.inflated_samples,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_every_weight_against_the_honest_step() {
        let w = forge(&[1.0, 1.0, 1.0], &[0.5, -0.25, 0.0], 0.125);
        assert_eq!(w, vec![0.875, 1.125, 0.875]);
    }
}

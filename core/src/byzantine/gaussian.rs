//! `gaussian`: w(t) plus independent Gaussian noise, `w_i = w_i(t) + sigma * z_i` with `z_i`
//! standard normal (`Rng::normal`, one draw per weight in index order).
//! Information: w(t). Parameters: `byzantine.sigma`, `byzantine.claimed_samples`.

use super::{submit, Action, Attack, View};
use crate::rng::Rng;

/// The `gaussian` agent.
pub struct Gaussian;

/// The noisy model.
pub fn forge(shared: &[f32], sigma: f64, rng: &mut Rng) -> Vec<f32> {
    shared
        .iter()
        .map(|&w| (f64::from(w) + sigma * rng.normal()) as f32)
        .collect()
}

impl Attack for Gaussian {
    fn act(&self, view: &View, rng: &mut Rng) -> Action {
        submit(view, forge(&view.shared(), view.config.sigma, rng))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{self, Purpose};

    #[test]
    fn noise_has_the_configured_spread() {
        let shared = vec![1.0f32; 20_000];
        let w = forge(&shared, 0.5, &mut rng::stream(1, Purpose::Byzantine, 0));
        let d: Vec<f64> = w.iter().map(|&x| f64::from(x) - 1.0).collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / d.len() as f64;
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!((var.sqrt() - 0.5).abs() < 0.02, "std {}", var.sqrt());
        assert_eq!(
            forge(&shared, 0.0, &mut rng::stream(1, Purpose::Byzantine, 0)),
            shared
        );
    }
}

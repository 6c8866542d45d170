//! `clipping`, static clipping (as ByzFL's `Clipping(c)`; the clipped-gradient analysis of
//! Karimireddy et al., ICML 2021, and Gorbunov et al.): every update `x_k = w_k - w(t)` whose
//! L2 norm exceeds the radius `c` (`contract.clip_radius`) is scaled back onto the sphere,
//!
//! `y_k = w(t) + x_k min(1, c / |x_k|)`,
//!
//! so no single submission moves the aggregate by more than `c` times its weight in the rule.
//! A fixed `c` is a guess of the honest step size: too small and honest progress is slowed,
//! too large and it clips nothing (`arc` chooses it from the round).
//!
//! Integers: `c` in fixed-point units (`round(clip_radius * weight_scale)`), the norm
//! `floor(sqrt(.))` of the exact squared distance, each coordinate `x_i c / |x|` rounded half
//! away from zero ([`super::clip_to`]). Samples unchanged.

use super::{clip_to, Staged};

/// The stage as its line in the [`Preaggregator`](crate::config::Preaggregator) registry
/// names it.
pub struct Clipping;

impl super::Stage for Clipping {
    fn apply(&self, models: &[Staged], stage: &super::StageInput) -> Vec<Staged> {
        apply(models, stage.current, stage.params.clip_radius_units)
    }
}

/// Every update clipped to `radius_units` around `current`.
pub fn apply(models: &[Staged], current: &[i64], radius_units: u64) -> Vec<Staged> {
    models
        .iter()
        .map(|m| Staged {
            weights: clip_to(&m.weights, current, u128::from(radius_units)),
            samples: m.samples,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::staged_of;
    use super::*;

    #[test]
    fn long_updates_are_scaled_onto_the_sphere() {
        // Around (10, 10), radius 5: update (3, 4) has norm 5 and stays; (30, 40) has norm 50
        // and becomes (3, 4); (-7, 1): |x|^2 = 50, floor(sqrt) = 7 > 5:
        // -7 * 5 / 7 = -5, 1 * 5 / 7 = 0.71 -> 1.
        let out = apply(&staged_of(&[&[13, 14], &[40, 50], &[3, 11]]), &[10, 10], 5);
        let w: Vec<Vec<i64>> = out.iter().map(|s| s.weights.clone()).collect();
        assert_eq!(w, vec![vec![13, 14], vec![13, 14], vec![5, 11]]);
    }

    #[test]
    fn negative_halves_round_away_from_zero() {
        // Update (-3) at radius 1 ... norm 3: -3 * 1 / 3 = -1; update (-5, 0) radius 2: -2.
        // Update (-1, -1): |x|^2 = 2, norm 1 <= 1: kept.
        let out = apply(&staged_of(&[&[-3, 0], &[-1, -1]]), &[0, 0], 1);
        assert_eq!(out[0].weights, vec![-1, 0]);
        assert_eq!(out[1].weights, vec![-1, -1]);
        // -5 * 3 / 4 = -3.75 -> -4 with |(-5, 3)|: 34 -> floor sqrt 5: -5 * 4 / 5 = -4,
        // 3 * 4 / 5 = 2.4 -> 2.
        let out = apply(&staged_of(&[&[-5, 3]]), &[0, 0], 4);
        assert_eq!(out[0].weights, vec![-4, 2]);
    }
}

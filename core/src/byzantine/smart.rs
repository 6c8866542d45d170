//! `smart`: follows the trend of the shared model to be ranked first (docs/SPEC.md section 5).
//!
//! - paper: `w_i(t) + 2 r_i Delta`, `Delta = (1/N) sum_i |w_i(t) - w_i(t-1)|`, `r_i` uniform in
//!   [0, 1) drawn per weight, always N draws. In round 0 there is no w(t-1): we take
//!   `Delta = 0`, so the robot sends w(t) (the formula with w(t-1) = w(t)).
//! - reference: positive-only noise of the magnitude of one step, `w_i(t) + r_i Delta` with
//!   `r_i` uniform in [0, 1) (our reading of docs/SPEC.md: the paper's variation `2 r Delta` has mean
//!   Delta and reaches 2 Delta, the reference's stays within one Delta above w(t)), and w(t)
//!   unchanged, with no draws, before the first change (no w(t-1), or Delta == 0).
//!
//! Uses w(t) and w(t-1) from its own chain.

use super::delta;
use crate::config::ByzantineVariant;
use crate::rng::Rng;

/// The smart robot's weights for `variant`.
pub fn forge(
    variant: ByzantineVariant,
    shared: &[f32],
    previous: Option<&[f32]>,
    rng: &mut Rng,
) -> Vec<f32> {
    let step = previous.map_or(0.0, |p| delta(shared, p));
    match variant {
        ByzantineVariant::Paper => shared
            .iter()
            .map(|&w| (f64::from(w) + 2.0 * rng.uniform() * step) as f32)
            .collect(),
        ByzantineVariant::Reference if step == 0.0 => shared.to_vec(),
        ByzantineVariant::Reference => shared
            .iter()
            .map(|&w| (f64::from(w) + rng.uniform() * step) as f32)
            .collect(),
    }
}

/// The `smart` agent. Parameters: `byzantine.variant`, `byzantine.claimed_samples`.
pub struct Smart;

impl super::Attack for Smart {
    fn act(&self, view: &super::View, rng: &mut Rng) -> super::Action {
        let shared = view.shared();
        let previous = view.previous();
        let weights = forge(view.config.variant, &shared, previous.as_deref(), rng);
        super::submit(view, weights)
    }
}

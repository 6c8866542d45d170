//! `smart`: follows the trend of the shared model to be ranked first (docs/SPEC.md section 5).
//!
//! - paper: `w_i(t) + 2 r_i Delta`, `Delta = (1/N) sum_i |w_i(t) - w_i(t-1)|`, `r_i` uniform in
//!   [0, 1) drawn per weight, always N draws. In round 0 there is no w(t-1): we take
//!   `Delta = 0`, so the robot sends w(t) (the formula with w(t-1) = w(t)).
//! - reference: positive-only noise of the magnitude of one step, `w_i(t) + r_i Delta` with
//!   `r_i` uniform in [0, 1) (our reading of docs/SPEC.md: the paper's variation `2 r Delta` has mean
//!   Delta and reaches 2 Delta, the reference's stays within one Delta above w(t)), and w(t)
//!   unchanged, with no draws, before the first change (no w(t-1), or Delta == 0).
//! - authors: the code as it runs (`controllers/docker/fedlerv2.py`, `bad_behaviour` with
//!   rtype 2: `elem + int(random.random() * mae * 2)`): `w_i(t) + 2 r_i Delta`, `r_i` uniform
//!   in [0, 1) per weight, and before the first aggregation (our round 0, their version 1)
//!   w(t-1) is all zeros: the robot read the contract's weights before robot 1 set the
//!   initial ones, so when version 1 arrived its `previous` became those zeros. Its first
//!   submission is then `w(0)` plus up to twice the mean absolute weight, an outlier. The
//!   code truncates each addition to an integer number of 1e-9 units; we add in f64 and round
//!   to the contract's fixed point (a difference of at most one unit per weight).
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
    let step = match (variant, previous) {
        (_, Some(p)) => delta(shared, p),
        (ByzantineVariant::Authors, None) => delta(shared, &vec![0.0; shared.len()]),
        (_, None) => 0.0,
    };
    match variant {
        ByzantineVariant::Paper | ByzantineVariant::Authors => shared
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

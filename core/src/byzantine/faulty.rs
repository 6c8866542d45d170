//! `faulty`: every weight uniform in `[-byzantine.faulty_range, faulty_range)` (both variants;
//! the paper's interval is TensorFlow's initialisation range, 0.5). Uses no information.

use crate::rng::Rng;

/// `len` weights uniform in `[-range, range)`, one draw each, in index order.
pub fn forge(len: usize, range: f64, rng: &mut Rng) -> Vec<f32> {
    assert!(range.is_finite() && range >= 0.0, "faulty_range {range}");
    (0..len).map(|_| rng.range(-range, range) as f32).collect()
}

/// The `faulty` agent. Parameters: `byzantine.faulty_range`, `byzantine.claimed_samples`.
pub struct Faulty;

impl super::Attack for Faulty {
    fn act(&self, view: &super::View, rng: &mut Rng) -> super::Action {
        let len = view.chain.weights.len();
        super::submit(view, forge(len, view.config.faulty_range, rng))
    }
}

//! `malicious`: resubmits the shared model w(t) read from its own chain (both variants).

/// The shared model itself.
pub fn forge(shared: &[f32]) -> Vec<f32> {
    shared.to_vec()
}

/// The `malicious` agent. Parameter: `byzantine.claimed_samples`.
pub struct Malicious;

impl super::Attack for Malicious {
    fn act(&self, view: &super::View, _rng: &mut crate::rng::Rng) -> super::Action {
        super::submit(view, forge(&view.shared()))
    }
}

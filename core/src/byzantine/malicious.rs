//! `malicious`: resubmits the shared model w(t) read from its own chain (both variants).

/// The shared model itself.
pub fn forge(shared: &[f32]) -> Vec<f32> {
    shared.to_vec()
}

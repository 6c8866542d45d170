//! Trajectory data: the samples a robot records about its neighbours (SPEC.md section 1).
//!
//! Placeholder types fixed here so that `world` (which produces samples) and `learn` (which
//! consumes them) agree; the world issue fills in collection, expiry and the held-out set.

use serde::{Deserialize, Serialize};

use crate::types::SimTime;

/// One training example cut from a 100-tick trajectory of a neighbour: `input_waypoints`
/// (x, y) positions followed by `target_waypoints` positions, in world metres (not normalised).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// When the trajectory was completed; the sample expires `data.expiration_s` after this.
    pub time: SimTime,
    /// Input waypoints then target waypoints, each an (x, y) pair.
    pub points: Vec<[f32; 2]>,
}

//! The claim bound (`contract.max_claimed_samples`; beyond the paper, whose contract, like the
//! authors' `federatedsc3V2.sol`, takes any claimed sample count up to its int bounds).
//!
//! FedAvg weights each model by the samples its sender claims, and the paper's reward rule
//! pays a rank by them too, so a claim the contract cannot check is a lever: a robot claiming
//! 10^9 samples takes the whole bonus of every round it is ranked in and pulls the shared model
//! its way (issue 37). The contract cannot see a robot's data, but it can know the most a robot
//! can *physically* have, and refuses any claim above it.
//!
//! # The derivation (the default, `max_claimed_samples = 0`)
//!
//! - A sample is one trajectory of one neighbour over `data.trajectory_ticks` consecutive
//!   ticks; windows of the same neighbour never overlap (`data.rs`), so a neighbour yields at
//!   most one sample per `T = trajectory_ticks * tick` milliseconds, and these complete on
//!   ticks at least `T` apart.
//! - A robot hears at most the `world.robots - 1` other robots.
//! - A sample stays in the data set while its age is at most `E = data.expiration_s`
//!   (expired every tick, `Recorder::expire`): completions at least `T` apart fit at most
//!   `floor(E / T) + 1` times in the closed window of length `E`.
//! - The learner trains on the first `learn.train_fraction` of its data set
//!   (`learn::split_point`) and claims that count (`train_samples`); `split_point` is
//!   monotone in the data set's size.
//!
//! So an honest claim is never above `split_point((robots - 1) * (floor(E / T) + 1),
//! train_fraction)`: 851 for `paper` (14 neighbours x 76 samples = 1,064; 80 % of it, floored),
//! whatever the robots' paths. Every honest submission stays accepted, and a fixture's record
//! is unchanged (honest robots and the attacks that claim `byzantine.claimed_samples = 200`
//! are below it).
//!
//! # What an over-claim gets
//!
//! It is refused as malformed before any stake moves, with the reason recorded in its
//! receipt, like every other impossible call (zero samples, a wrong length): the sender's turn
//! is not used, nothing changes. Clamping the claim to the bound instead would still let an
//! attacker claim the bound, above any honest robot's real count, every round; refusing gives
//! an inflated claim nothing at all.

use super::{ContractParams, MAX_SAMPLES, MAX_WEIGHT_MAGNITUDE};
use crate::config::Config;
use crate::learn::split_point;
use crate::types::SimTime;
use serde::{Deserialize, Serialize};

/// The most samples a robot can hold for training under `config` (the derivation above),
/// at least 1 and at most the contract's hard limit [`MAX_SAMPLES`].
pub fn derived_max_samples(config: &Config) -> u64 {
    let tick_ms = SimTime::from_secs(config.run.tick_s).0.max(1);
    let window_ms = u64::from(config.data.trajectory_ticks).saturating_mul(tick_ms);
    let expiration_ms = SimTime::from_secs(config.data.expiration_s).0;
    let per_neighbour = (expiration_ms / window_ms.max(1)).saturating_add(1);
    let neighbours = u64::from(config.world.robots.saturating_sub(1));
    let collectable = neighbours.saturating_mul(per_neighbour).min(MAX_SAMPLES);
    let trained = split_point(collectable as usize, config.learn.train_fraction) as u64;
    trained.clamp(1, MAX_SAMPLES)
}

/// The claim bound a run's contract enforces: `contract.max_claimed_samples`, or the derived
/// one when that is 0.
pub fn max_samples(config: &Config) -> u64 {
    match config.contract.max_claimed_samples {
        0 => derived_max_samples(config),
        explicit => explicit.min(MAX_SAMPLES),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Preset;

    #[test]
    fn the_paper_bound_is_851() {
        let c = Preset::Paper.config();
        assert_eq!(derived_max_samples(&c), 851);
        assert_eq!(max_samples(&c), 851);
    }

    #[test]
    fn the_bound_follows_the_data_window() {
        let mut c = Preset::Paper.config();
        c.data.expiration_s = 250.0;
        // 14 x (25 + 1) = 364, 80 % = 291.
        assert_eq!(derived_max_samples(&c), 291);
        c.world.robots = 30;
        // 29 x 26 = 754, 80 % = 603.
        assert_eq!(derived_max_samples(&c), 603);
        c.contract.max_claimed_samples = 10;
        assert_eq!(max_samples(&c), 10);
        c.world.robots = 1;
        c.contract.max_claimed_samples = 0;
        assert_eq!(derived_max_samples(&c), 1, "never below one sample");
    }
}

/// The claim bound of [`super::ContractParams`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClaimBound {
    /// The largest sample count a submission may claim, at most [`MAX_SAMPLES`].
    pub max_samples: u64,
    /// Set by `contract.max_claimed_samples` rather than derived from the data window.
    pub explicit: bool,
}

impl Default for ClaimBound {
    /// The contract's hard limit only (what hand-made parameters in tests get).
    fn default() -> ClaimBound {
        ClaimBound {
            max_samples: MAX_SAMPLES,
            explicit: false,
        }
    }
}

impl ClaimBound {
    /// The bound of a run's configuration: explicit, or derived when the key is 0.
    pub fn from_config(config: &Config) -> ClaimBound {
        ClaimBound {
            max_samples: max_samples(config),
            explicit: config.contract.max_claimed_samples != 0,
        }
    }

    /// Not set explicitly (left out of the parameters' encoding).
    pub fn is_derived(&self) -> bool {
        !self.explicit
    }
}

/// The reason text of a claim above the bound `bound` (both engines word it so).
pub fn over_claim(samples: u64, bound: u64) -> String {
    if bound == MAX_SAMPLES {
        // The hard limit's text, as records made before the claim bound have it.
        format!("samples {samples} exceed the limit {MAX_SAMPLES}")
    } else {
        format!("samples {samples} exceed the claim bound {bound} (contract.max_claimed_samples)")
    }
}

/// Why a model is malformed, if it is (check 3 of the contract's module doc): no samples, a
/// claim over the bound, the wrong length or a weight outside int48.
pub(super) fn check_model(
    params: &ContractParams,
    weights: &[i64],
    samples: u64,
) -> Result<(), String> {
    let model_len = params.model_len();
    if samples == 0 {
        return Err("samples must be at least 1, got 0".to_string());
    }
    if samples > params.claim_bound.max_samples {
        return Err(over_claim(samples, params.claim_bound.max_samples));
    }
    if weights.len() != model_len {
        return Err(format!(
            "model has {} weights, the shared model has {model_len}",
            weights.len()
        ));
    }
    if let Some((i, w)) = weights
        .iter()
        .enumerate()
        .find(|(_, w)| w.unsigned_abs() >= MAX_WEIGHT_MAGNITUDE)
    {
        return Err(format!("weight {i} = {w} is outside int48 (|w| < 2^47)"));
    }
    Ok(())
}

//! `smart-then-collude`: the attack the paper's conclusion warns about. The Byzantine robots
//! act `smart` (farm rewards with guesses of the next model, [`super::smart`]) until, on the
//! robot's *own* chain, they together hold more than `byzantine.switch_token_share` of the
//! robots' tokens (balances at its head; 0.5 = more than the honest robots together); from then
//! on they all submit one coordinated harmful model, the `collude` model ([`super::collude`]:
//! the swarm's last step reversed and flattened to `byzantine.threshold_fraction` of the
//! outlier threshold, so the paper's threshold accepts it), claiming
//! `byzantine.claimed_samples` each. The switch is not a latch: a robot decides at every phase
//! from its chain, so if the coalition's share falls back below the threshold (colluders stop
//! earning) its robots act smart again, and switch again when they are back above it.
//!
//! Information: its chain's balances (every node knows every balance), the coalition's
//! members, w(t), w(t-1) and the contract's threshold. Parameters: `byzantine.variant`,
//! `byzantine.switch_token_share`, `byzantine.threshold_fraction`,
//! `byzantine.claimed_samples`. The first block of the final canonical chain at which the
//! share is above the threshold is `tokens.byzantine_control` in `summary.json`
//! (`swarmfl bisect LOG --until "byzantine_share > 0.5"` finds it).

use super::{collude::Collude, smart::Smart, Action, Attack, View};
use crate::metrics;
use crate::rng::Rng;

/// The Byzantine share of the robots' balances on `view`'s chain ([`metrics::byzantine_share`]).
pub fn byzantine_share(view: &View) -> f64 {
    metrics::byzantine_share(&view.chain.balances, view.coalition)
}

/// True when the coalition holds more than `byzantine.switch_token_share` on `view`'s chain.
pub fn in_control(view: &View) -> bool {
    byzantine_share(view) > view.config.switch_token_share
}

/// The `smart-then-collude` agent.
pub struct SmartThenCollude;

impl Attack for SmartThenCollude {
    fn act(&self, view: &View, rng: &mut Rng) -> Action {
        if in_control(view) {
            Collude.act(view, rng)
        } else {
            Smart.act(view, rng)
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::config::Preset;
    use crate::contract::{ContractParams, ContractState};
    use crate::rng::{self, Purpose};
    use crate::world::World;

    /// Smart while the coalition holds at most the share, the `collude` model above it, and the
    /// switch reads the robot's own chain's balances.
    #[test]
    fn switches_from_smart_to_collude_above_the_token_share() {
        let mut config = Preset::Smoke.config();
        config.byzantine.kind = crate::config::ByzantineKind::SmartThenCollude;
        config.byzantine.count = 2;
        let world = World::new(&config, 1).expect("a world");
        let scale = config.contract.weight_scale as i64;
        let params = ContractParams::from_config(&config, Arc::from(vec![0i64; 4]));
        let mut chain = ContractState::genesis(&params);
        chain.weights = Arc::from(vec![scale / 2; 4]);
        chain.previous_weights = Some(Arc::from(vec![0i64; 4]));
        let mut coalition = vec![false; 15];
        coalition[3] = true;
        coalition[8] = true;
        let act = |chain: &ContractState| -> Action {
            let view = View {
                robot: 3,
                now_ms: 0,
                last_chance: false,
                chain,
                params: &params,
                weight_scale: config.contract.weight_scale,
                coalition: &coalition,
                world: &world,
                config: &config.byzantine,
                input_waypoints: 32,
            };
            let mut rng = rng::stream(1, Purpose::Byzantine, 3);
            SmartThenCollude.act(&view, &mut rng)
        };
        let weights = |a: Action| match a {
            Action::Submit { weights, samples } => {
                assert_eq!(samples, config.byzantine.claimed_samples);
                weights
            }
            other => panic!("submits, got {other:?}"),
        };
        // 2 of 15 robots: share 2/15, smart: above w(t) (the paper's positive offsets).
        let smart = weights(act(&chain));
        assert!(smart.iter().all(|&w| w >= 0.5), "{smart:?}");
        // Move tokens to the coalition until it holds exactly half: still smart.
        let total: u64 = chain.balances.iter().sum();
        chain.balances = vec![0; 15];
        chain.balances[3] = total / 4;
        chain.balances[8] = total / 4;
        chain.balances[0] = total - total / 2;
        assert!(weights(act(&chain)).iter().all(|&w| w >= 0.5));
        // One unit more: collude, the last step (+0.5) reversed by 0.99 x threshold (0.05).
        chain.balances[0] -= 1;
        chain.balances[8] += 1;
        let collude = weights(act(&chain));
        for w in collude {
            assert!((f64::from(w) - (0.5 - 0.99 * 0.05)).abs() < 1e-6, "{w}");
        }
    }
}

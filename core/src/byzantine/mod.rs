//! Byzantine robots: which robots they are ([`byzantine_robots`]) and the agents that decide
//! what each one submits ([`Attack`], one file per `byzantine.kind`).
//!
//! Byzantine robots move and run nodes like everyone. At each of its learning phases the
//! driver asks the robot's attack what to do, giving it a [`View`]: exactly what its own node
//! knows (the contract state at its own chain's head, including the current round's
//! submissions already sealed there, the public contract rules, its own trajectories) plus
//! which robots are its accomplices. The attack answers with an [`Action`]: submit a model
//! with a claimed sample count, train honestly on given samples and submit the result, or
//! wait. A waiting robot is asked again at every tick with a fresh view until it acts or its
//! next phase is due (then the phase is skipped, reason `waited`); this is how the attacks
//! that read the honest models of the round wait for `byzantine.wait_for_honest` of them. The
//! driver (`sim.rs`) never knows which attack runs.
//!
//! The attacks (each file documents its formula, parameters and the information it uses):
//! `faulty`, `malicious`, `smart` (the paper's, docs/SPEC.md section 5), `sign-flip`, `gaussian`,
//! `alie`, `ipm`, `min-max`, `mimic`, `inflate-samples`, `poison-data`, `collude`,
//! `smart-then-collude` (the paper's open problem: smart until the coalition holds a token
//! share, then one harmful model), and the adaptive and extreme attacks of issue 33:
//! `optimal-alie` and `optimal-ipm` (their factor line-searched against the contract's own
//! pre-aggregators and rule on the robot's chain, `line_search.rs`), `extreme-value` (every weight at the
//! edge of int48) and `mirror-targets` (label flipping for trajectories); `plugin` runs an
//! attack the program running the simulation supplies (`plugin.rs`). Models are
//! computed in `f64` in index order without fused multiply-add and rounded once to `f32`; the
//! driver converts them to fixed point as it does honest models.

pub mod ledger;
pub mod line_search;
pub mod plugin;

use crate::config::{ByzantineConfig, ByzantineKind, Config};
use crate::contract::{ContractParams, ContractState, Submission};
use crate::data::Sample;
use crate::learn;
use crate::rng::{self, Purpose, Rng};
use crate::types::RobotId;
use crate::world::World;

/// What a Byzantine robot knows when it decides: its own node's view, nothing more.
pub struct View<'a> {
    /// The robot.
    pub robot: RobotId,
    /// Simulated time of the decision, in ms.
    pub now_ms: u64,
    /// True when the robot's next learning phase is due: waiting now skips this phase.
    pub last_chance: bool,
    /// The contract state at the head of the robot's own chain.
    pub chain: &'a ContractState,
    /// The contract rules in force (public: every node executes them).
    pub params: &'a ContractParams,
    /// Fixed-point scale of on-chain weights.
    pub weight_scale: u64,
    /// Which robots are Byzantine: the coalition knows its members (index = robot id).
    pub coalition: &'a [bool],
    /// The world, to read this robot's own trajectories ([`View::own_dataset`]).
    pub world: &'a World,
    /// The attack's parameters.
    pub config: &'a ByzantineConfig,
    /// Input waypoints per sample (`data.input_waypoints`): the rest are targets.
    pub input_waypoints: usize,
}

impl View<'_> {
    /// w(t), the shared model at the head of its chain.
    pub fn shared(&self) -> Vec<f32> {
        learn::from_fixed(&self.chain.weights, self.weight_scale)
    }

    /// w(t-1), the model before the last aggregation, if there was one.
    pub fn previous(&self) -> Option<Vec<f32>> {
        self.chain
            .previous_weights
            .as_ref()
            .map(|w| learn::from_fixed(w, self.weight_scale))
    }

    /// The current round's submissions on its chain from robots outside the coalition, in
    /// submission order (accepted and outliers: both are public).
    pub fn honest_submissions(&self) -> Vec<&Submission> {
        self.chain
            .submissions
            .iter()
            .filter(|s| !self.in_coalition(s.sender))
            .collect()
    }

    /// The models of [`View::honest_submissions`], as floats: their weights, or under the
    /// buffered protocol their updates rebased on the shared model (so an attack reads the
    /// buffer as it reads a round: every model relative to `w(t)`, whatever its base).
    pub fn honest_models(&self) -> Vec<Vec<f32>> {
        self.honest_fixed()
            .into_iter()
            .map(|w| learn::from_fixed(w, self.weight_scale))
            .collect()
    }

    /// The fixed-point models of [`View::honest_submissions`] (see [`View::honest_models`]).
    pub fn honest_fixed(&self) -> Vec<&[i64]> {
        let chain = self.chain;
        (0..chain.submissions.len())
            .filter(|&i| !self.in_coalition(chain.submissions[i].sender))
            .map(|i| &chain.round_model(i)[..])
            .collect()
    }

    fn in_coalition(&self, robot: RobotId) -> bool {
        self.coalition.get(robot as usize).copied().unwrap_or(false)
    }

    /// The outlier bound in force as a mean absolute distance per weight (public contract
    /// rule and state): `contract.outlier_threshold`, or under the relative rule the bound
    /// its chain's window sets now (`contract/outlier.rs`).
    pub fn threshold(&self) -> f64 {
        self.chain.outlier_bound(self.params, self.weight_scale)
    }

    /// The robot's own current trajectories.
    pub fn own_dataset(&self) -> Vec<Sample> {
        self.world.dataset(self.robot)
    }
}

/// What a Byzantine robot does now.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Nothing yet: ask again at the next tick (or skip the phase on the last chance).
    Wait,
    /// Submit these weights claiming `samples` training samples.
    Submit {
        /// The model (converted to fixed point by the driver).
        weights: Vec<f32>,
        /// The claimed sample count.
        samples: u32,
    },
    /// Train honestly from w(t) on these samples and submit the result, claiming the training
    /// samples.
    Train {
        /// The (possibly corrupted) trajectories.
        samples: Vec<Sample>,
    },
}

/// A Byzantine behaviour: an agent that sees its node's view and returns an action.
pub trait Attack: Send + Sync {
    /// The action for `view`; `rng` is the robot's `Purpose::Byzantine` substream of the
    /// learning phase (restarted at each ask, so only the acting ask's draws count).
    fn act(&self, view: &View, rng: &mut Rng) -> Action;
}

/// The agent of `config`'s `byzantine.kind` (a plug-in's from `plugins`, by its
/// `byzantine.plugin` name); `Ok(None)` for honest robots, an error naming the plug-in when it
/// is not offered.
pub fn agent(
    config: &ByzantineConfig,
    plugins: &plugin::Plugins,
) -> Result<Option<std::sync::Arc<dyn Attack>>, String> {
    Ok(match config.kind {
        ByzantineKind::Plugin => Some(plugin::lookup(plugins, &config.plugin)?),
        kind => attack(kind).map(std::sync::Arc::from),
    })
}

/// Writes `pub mod file;` for each attack line of the [`ByzantineKind`] registry
/// (`config/byzantine.rs`: `Alie = "alie" in alie`) and [`attack`], the `match` from each kind
/// to a new agent of the type of its name in its file (`alie::Alie`). The lines without a file
/// are handled here by name, so any other line without one does not compile.
macro_rules! declare_attacks {
    (ByzantineKind: $( $Kind:ident $(in $file:ident)? ),+) => {
        $( $( pub mod $file; )? )+

        /// The built-in agent of `kind`; `None` for honest robots and for `plugin` (see
        /// [`agent`]).
        pub fn attack(kind: ByzantineKind) -> Option<Box<dyn Attack>> {
            match kind {
                $( ByzantineKind::$Kind => declare_attacks!(@agent $Kind $($file)?), )+
            }
        }
    };
    // Honest robots have no agent; a plug-in's comes from the program that runs the
    // simulation (`agent`, `plugin.rs`).
    (@agent None) => { None };
    (@agent Plugin) => { None };
    (@agent $Kind:ident $file:ident) => { Some(Box::new($file::$Kind)) };
}

crate::config::attack_files!(declare_attacks);

/// Submits `weights` with the configured `byzantine.claimed_samples`.
pub fn submit(view: &View, weights: Vec<f32>) -> Action {
    Action::Submit {
        weights,
        samples: view.config.claimed_samples,
    }
}

/// The honest models of the round once at least `need` are on the chain; `None` (wait)
/// before.
pub fn await_honest(view: &View, need: usize) -> Option<Vec<Vec<f32>>> {
    if view.honest_submissions().len() < need.max(1) {
        return None;
    }
    Some(view.honest_models())
}

/// Per-weight mean of `models` (non-empty, one length), in `f64`, summed in model order.
pub fn mean(models: &[Vec<f32>]) -> Vec<f64> {
    let n = models.len() as f64;
    (0..models[0].len())
        .map(|i| models.iter().map(|m| f64::from(m[i])).sum::<f64>() / n)
        .collect()
}

/// Per-weight population standard deviation of `models` around `mean`, in `f64`.
pub fn std_dev(models: &[Vec<f32>], mean: &[f64]) -> Vec<f64> {
    let n = models.len() as f64;
    mean.iter()
        .enumerate()
        .map(|(i, &mu)| {
            let var = models
                .iter()
                .map(|m| {
                    let d = f64::from(m[i]) - mu;
                    d * d
                })
                .sum::<f64>()
                / n;
            var.sqrt()
        })
        .collect()
}

/// Rounds an `f64` model to `f32`.
pub fn to_f32(model: &[f64]) -> Vec<f32> {
    model.iter().map(|&w| w as f32).collect()
}

/// `Delta(w(t), w(t-1)) = (1/N) sum_i |w_i(t) - w_i(t-1)|`, in `f64`, summed in index order.
/// 0 for empty models.
pub fn delta(current: &[f32], previous: &[f32]) -> f64 {
    assert_eq!(
        current.len(),
        previous.len(),
        "Delta between models of different lengths"
    );
    if current.is_empty() {
        return 0.0;
    }
    let sum: f64 = current
        .iter()
        .zip(previous)
        .map(|(&a, &b)| (f64::from(a) - f64::from(b)).abs())
        .sum();
    sum / current.len() as f64
}

/// Which robots are Byzantine: `byzantine.count` of the `world.robots`, drawn without
/// replacement (a partial Fisher-Yates shuffle) from the `Purpose::ByzantineSelection` stream,
/// so they are spread over the ids and change with the seed. Index = robot id.
pub fn byzantine_robots(config: &Config, seed: u64) -> Vec<bool> {
    let robots = config.world.robots as usize;
    let count = (config.byzantine.count as usize).min(robots);
    let mut ids: Vec<usize> = (0..robots).collect();
    let mut rng = rng::stream(seed, Purpose::ByzantineSelection, 0);
    for i in 0..count {
        let j = i + rng.below((robots - i) as u64) as usize;
        ids.swap(i, j);
    }
    let mut byzantine = vec![false; robots];
    for &id in &ids[..count] {
        byzantine[id] = true;
    }
    assert_eq!(byzantine.iter().filter(|&&b| b).count(), count);
    byzantine
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ByzantineVariant, Preset};

    fn stream() -> Rng {
        rng::stream(42, Purpose::Byzantine, 3)
    }

    fn forge_with(
        kind: ByzantineKind,
        variant: ByzantineVariant,
        shared: &[f32],
        previous: Option<&[f32]>,
    ) -> Vec<f32> {
        let mut rng = stream();
        match kind {
            ByzantineKind::Faulty => faulty::forge(shared.len(), 0.5, &mut rng),
            ByzantineKind::Malicious => malicious::forge(shared),
            ByzantineKind::Smart => smart::forge(variant, shared, previous, &mut rng),
            _ => unreachable!("the classic kinds"),
        }
    }

    #[test]
    fn faulty_weights_are_uniform_in_the_range_and_seeded() {
        let shared = vec![3.0f32; 10_000];
        let w = forge_with(
            ByzantineKind::Faulty,
            ByzantineVariant::Paper,
            &shared,
            None,
        );
        assert!(w.iter().all(|x| (-0.5..=0.5).contains(x)));
        let mean = w.iter().map(|&x| f64::from(x)).sum::<f64>() / w.len() as f64;
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!(w.iter().any(|&x| x < -0.45) && w.iter().any(|&x| x > 0.45));
        assert_eq!(
            w,
            forge_with(
                ByzantineKind::Faulty,
                ByzantineVariant::Reference,
                &shared,
                None
            )
        );
    }

    #[test]
    fn malicious_resubmits_the_shared_model() {
        let shared = [0.25f32, -1.5, 7.0];
        for variant in [ByzantineVariant::Paper, ByzantineVariant::Reference] {
            assert_eq!(
                forge_with(ByzantineKind::Malicious, variant, &shared, Some(&[0.0; 3])),
                shared
            );
        }
    }

    #[test]
    fn delta_is_the_mean_absolute_change() {
        fn check(current: &[f32], previous: &[f32], expect: f64) {
            assert_eq!(delta(current, previous), expect);
        }
        check(&[1.0, 2.0, 3.0, 4.0], &[0.0, 2.0, 5.0, 4.0], 0.75);
        check(&[-1.0, 1.0], &[1.0, -1.0], 2.0);
        check(&[], &[], 0.0);
    }

    /// Smart, paper: offsets 2 r Delta lie in [0, 2 Delta) and average Delta.
    #[test]
    fn smart_paper_adds_twice_a_uniform_fraction_of_the_last_step() {
        let n = 20_000;
        let shared: Vec<f32> = (0..n).map(|i| (i % 7) as f32 * 0.125).collect();
        let previous: Vec<f32> = shared.iter().map(|w| w - 0.25).collect(); // Delta = 0.25
        let w = forge_with(
            ByzantineKind::Smart,
            ByzantineVariant::Paper,
            &shared,
            Some(&previous),
        );
        let offsets: Vec<f64> = w
            .iter()
            .zip(&shared)
            .map(|(&a, &b)| f64::from(a) - f64::from(b))
            .collect();
        assert!(
            offsets.iter().all(|&o| (0.0..=0.5).contains(&o)),
            "offsets in [0, 2 Delta]"
        );
        let mean = offsets.iter().sum::<f64>() / n as f64;
        assert!((mean - 0.25).abs() < 0.01, "mean offset {mean}, Delta 0.25");
        // Round 0: Delta = 0, the robot sends w(t).
        assert_eq!(
            forge_with(ByzantineKind::Smart, ByzantineVariant::Paper, &shared, None),
            shared
        );
    }

    /// Smart, reference: offsets r Delta lie in [0, Delta) and average Delta / 2; before the
    /// first change w(t) is sent and no random number is drawn.
    #[test]
    fn smart_reference_adds_positive_noise_within_one_step() {
        let n = 20_000;
        let shared: Vec<f32> = (0..n).map(|i| (i % 5) as f32 * -0.5).collect();
        let previous: Vec<f32> = shared.iter().map(|w| w + 0.5).collect(); // Delta = 0.5
        let w = forge_with(
            ByzantineKind::Smart,
            ByzantineVariant::Reference,
            &shared,
            Some(&previous),
        );
        let offsets: Vec<f64> = w
            .iter()
            .zip(&shared)
            .map(|(&a, &b)| f64::from(a) - f64::from(b))
            .collect();
        assert!(offsets.iter().all(|&o| (0.0..=0.5).contains(&o)));
        let mean = offsets.iter().sum::<f64>() / n as f64;
        assert!(
            (mean - 0.25).abs() < 0.01,
            "mean offset {mean}, Delta / 2 = 0.25"
        );
        for previous in [None, Some(&shared[..])] {
            let mut rng = stream();
            let w = smart::forge(ByzantineVariant::Reference, &shared, previous, &mut rng);
            assert_eq!(w, shared);
            assert_eq!(rng, stream(), "no draws before the first change");
        }
    }

    /// Smart, authors: offsets 2 r Delta in [0, 2 Delta), mean Delta; before the first
    /// aggregation Delta is taken from all-zero weights (the mean absolute weight), so the
    /// first submission lands far from w(t), where the paper's variant sends w(t).
    #[test]
    fn smart_authors_adds_twice_the_step_and_starts_from_zeros() {
        let n = 20_000;
        let shared: Vec<f32> = (0..n).map(|i| (i % 5) as f32 * -0.5).collect(); // mean |w| 1
        let previous: Vec<f32> = shared.iter().map(|w| w + 0.5).collect(); // Delta = 0.5
        let offsets = |w: Vec<f32>| -> Vec<f64> {
            w.iter()
                .zip(&shared)
                .map(|(&a, &b)| f64::from(a) - f64::from(b))
                .collect()
        };
        let mean = |o: &[f64]| o.iter().sum::<f64>() / o.len() as f64;
        let later = offsets(forge_with(
            ByzantineKind::Smart,
            ByzantineVariant::Authors,
            &shared,
            Some(&previous),
        ));
        assert!(later.iter().all(|&o| (0.0..=1.0).contains(&o)));
        assert!((mean(&later) - 0.5).abs() < 0.01, "{}", mean(&later));
        let first = offsets(forge_with(
            ByzantineKind::Smart,
            ByzantineVariant::Authors,
            &shared,
            None,
        ));
        assert!(first.iter().all(|&o| (0.0..=2.0).contains(&o)));
        assert!((mean(&first) - 1.0).abs() < 0.02, "{}", mean(&first));
    }

    #[test]
    fn byzantine_robots_are_exactly_count_drawn_from_the_seed() {
        let mut config = Preset::Paper.config();
        for count in [0u32, 1, 3, 7, 15] {
            config.byzantine.count = count;
            let chosen = byzantine_robots(&config, 9);
            assert_eq!(chosen.len(), 15);
            assert_eq!(chosen.iter().filter(|&&b| b).count(), count as usize);
            assert_eq!(chosen, byzantine_robots(&config, 9), "deterministic");
        }
        config.byzantine.count = 3;
        let sets: Vec<Vec<bool>> = (0..8).map(|seed| byzantine_robots(&config, seed)).collect();
        assert!(
            sets.iter().any(|s| *s != sets[0]),
            "the choice depends on the seed"
        );
    }
}

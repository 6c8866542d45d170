//! The federated-learning smart contract, executed by every node on its own chain (docs/SPEC.md
//! section 4). Integer arithmetic only: weights are fixed point (`contract.weight_scale`),
//! tokens are integer units (`contract.token_units` per token).
//!
//! The contract is a pure reducer: [`ContractState::execute`] folds one call into the state and
//! returns its [`Outcome`]. Every node runs it on its own chain, so it must never panic on a
//! transaction: every bad input is an `Outcome` with a reason and leaves the state unchanged.
//!
//! # Rules, exactly
//!
//! `submitModel(w, n)` sent by `sender` with `value` attached is checked in this order; the first
//! failing check decides the outcome and nothing changes:
//! 1. `sender` is not an account: [`Outcome::Malformed`].
//! 2. `sender` already has a counted submission (accepted or outlier) in this round:
//!    [`Outcome::Duplicate`].
//! 3. `n == 0`, `n` above the claim bound (`contract.max_claimed_samples`, at most
//!    `MAX_SAMPLES` = 2^32 - 1, so that FedAvg sums fit in `i128`; by default the most a robot
//!    can collect in its data window, see [`claims`]), `len(w) != N` (the genesis model's
//!    length) or some `|w_i| >= 2^47` (the reference's int48): [`Outcome::Malformed`] with the
//!    reason.
//! 4. Security on only: `value < stake` or `balance < stake`: [`Outcome::InsufficientStake`];
//!    `value > stake`: [`Outcome::Malformed`] (the stake is exact, nothing is silently kept).
//!
//! Security on: the stake moves from the sender to the contract, then the model's distance
//! `d = sum_i |w_i - w_a,i|` decides: `d <= threshold_units * N` (the paper's mean distance
//! `<= 0.05`, exactly, in integers) is [`Outcome::Accepted`], otherwise [`Outcome::Outlier`]:
//! the stake stays in the round's pool and the sender has used its turn for the round.
//! Security off: `value` is ignored and no tokens move (the driver may send the same
//! transaction in both modes); every valid model is accepted.
//!
//! When the round holds `quorum` accepted models, the submission that completes it is
//! [`Outcome::Aggregated`]: the shared model becomes their FedAvg (see [`payout::fedavg`] for
//! the rounding), the round advances, and, security on, the accepted senders are ranked and paid
//! from the pool (see [`payout::rank`] and [`payout::payouts`]). The pool is everything the
//! contract holds: the round's stakes, accepted and outlier, plus the units carried over from
//! earlier rounds. What the integer payouts leave unpaid stays in the contract and is part of
//! the next round's pool.
//!
//! With a defence (`contract.defence`, [`defences`]) the payout of the used submissions follows
//! their agreement scores instead of the ranking; everything else above is unchanged.
//!
//! `transfer(to, amount)` needs `value == 0` and both accounts to exist ([`Outcome::Malformed`]
//! otherwise) and `amount <= balance` ([`Outcome::InsufficientFunds`] otherwise).
//!
//! After every call, `sum(balances) + holdings_units == robots * initial_units` is asserted.

pub mod buffered;
mod calls;
pub mod claims;
pub mod deadline;
pub mod defences;
#[cfg(feature = "evm")]
pub mod evm;
#[cfg(not(feature = "evm"))]
#[path = "evm_absent.rs"]
pub mod evm;
pub mod gas_limit;
pub mod options;
pub mod outlier;
pub mod payout;
pub mod preagg;
pub mod rank_order;
mod rewards;
pub mod rules;
mod submit;

#[cfg(test)]
mod test_support;
#[cfg(test)]
mod tests;

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::config::{Config, ContractEngine, ContractOptions, Defence, Rule};
use crate::types::{Digest, RobotId};

pub use calls::{Call, Outcome, Payout, RoundSummary, Submission, Verdict};
use claims::check_model;
pub use claims::{over_claim, ClaimBound};

/// Weights must satisfy `|w_i| < MAX_WEIGHT_MAGNITUDE` (2^47, the reference's int48).
pub const MAX_WEIGHT_MAGNITUDE: u64 = 1 << 47;

/// The largest sample count a submission may claim (2^32 - 1): keeps FedAvg's `sum(n_k w_k)`
/// far inside `i128`.
pub const MAX_SAMPLES: u64 = u32::MAX as u64;

/// The longest model the contract supports (2^16 weights): keeps distances inside `u64`.
pub const MAX_MODEL_LEN: usize = 1 << 16;

/// Parameters of the contract, fixed at genesis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContractParams {
    /// Number of robots (accounts).
    pub robots: u32,
    /// Units every account holds at genesis.
    pub initial_units: u64,
    /// Stake per submission, in units.
    pub stake_units: u64,
    /// Security mechanisms on or off.
    pub security: bool,
    /// Accepted submissions per aggregation.
    pub quorum: u32,
    /// Outlier threshold in fixed-point units of the mean absolute distance.
    pub outlier_threshold_units: i64,
    /// Reward weight per rank (+1 / -1), best first.
    pub reward_weights: Vec<i64>,
    /// The genesis model, fixed point.
    pub genesis_weights: Arc<[i64]>,
    /// Round deadline in ms of block time (0 = none; see `deadline.rs`). The genesis block
    /// commits to it as before deadlines were on by default: the presets' deadline
    /// ([`deadline::DEFAULT_ROUND_TIMEOUT_MS`]) is encoded as 0, so the records of runs whose
    /// deadline never fires do not move (see [`deadline::committed_timeout`]).
    #[serde(default, serialize_with = "deadline::committed_timeout")]
    pub round_timeout_ms: u64,
    /// A robust aggregation rule and its assumed Byzantine count; `None` for the paper's two
    /// rules (`fedavg` when `security` is off, `paper` when on). Left out of the encoding when
    /// `None`, so the parameters' digest of `paper` and `fedavg` runs is the one they had
    /// before rules could be chosen.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robust: Option<RobustRule>,
    /// The authors' variants of the paper's rule (docs/CONTRACT.md); committed to by the
    /// genesis block only when some option is not swarmfl's default, so default runs keep
    /// their hashes. Always the default with a robust rule (validation), so at most one of
    /// `robust` and `options` is ever encoded.
    #[serde(default, skip_serializing_if = "ContractOptions::is_default")]
    pub options: ContractOptions,
    /// A defence of the reward rule (`contract.defence`, see [`defences`]); `None` without
    /// one, and then left out of the encoding, so the parameters' digest of runs without a
    /// defence is the one they had before defences existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub defence: Option<defences::DefenceParams>,
    /// The pre-aggregator chain in front of the rule (`contract.preaggregators`, see
    /// [`preagg`]); `None` without stages, and then left out of the encoding, so the
    /// parameters' digest of runs without pre-aggregators is the one they had before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preagg: Option<preagg::PreaggParams>,
    /// The most samples a submission may claim (see [`claims`]). Committed to by the genesis
    /// block only when set explicitly: the derived bound follows from the configuration the
    /// log header records, so the parameters' digest of runs with it is the one they had
    /// before the bound existed.
    #[serde(default, skip_serializing_if = "ClaimBound::is_derived")]
    pub claim_bound: ClaimBound,
    /// Which machine executes the contract. Not part of the genesis commitment: both engines
    /// execute the same contract, so a run's chain is the same under either.
    #[serde(skip)]
    pub engine: ContractEngine,
    /// The most gas one block holds (`contract.block_gas_limit`; the `evm` engine refuses a
    /// call that needs more, the native engine has no gas). Like the engine, not part of the
    /// genesis commitment (the log's header records the configuration).
    #[serde(skip, default = "crate::config::default_block_gas_limit")]
    pub block_gas_limit: u64,
    /// The buffered protocol's parameters (`contract.protocol = "buffered"`, see [`buffered`]);
    /// `None` under the paper's rounds, and then left out of the encoding, so the parameters'
    /// digest of rounds runs is the one they had before the protocol existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub buffered: Option<buffered::BufferedParams>,
    /// The plug-in rule (`contract.rule = "plugin"`, see [`rules::plugin`]): its name and
    /// source digest, so that the genesis block commits to the rule's source; `None` under
    /// every built-in rule, and then left out of the encoding, so their parameters' digest is
    /// the one they had before plug-in rules existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rule_plugin: Option<rules::plugin::RuleId>,
    /// The relative outlier rule (`contract.outlier_rule = "relative"`, see [`outlier`]);
    /// `None` under the paper's absolute threshold, and then left out of the encoding, so the
    /// parameters' digest of every run without it is the one it had before the rule existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outlier: Option<outlier::RelativeOutlier>,
}

/// A robust rule of [`ContractParams`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RobustRule {
    /// The rule (never `fedavg` or `paper`).
    pub rule: Rule,
    /// Byzantine submissions per round the rule assumes (`contract.assumed_f`).
    pub assumed_f: u32,
    /// The paper's outlier threshold refuses submissions before the rule aggregates
    /// (`contract.threshold_gate`). Left out of the encoding when off, so the parameters of
    /// runs without it encode, and hash, as before the key existed.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub threshold_gate: bool,
}

impl ContractParams {
    /// The parameters of a run's contract.
    pub fn from_config(config: &Config, genesis_weights: Arc<[i64]>) -> ContractParams {
        let c = &config.contract;
        let rule = config.rule();
        ContractParams {
            robots: config.world.robots,
            initial_units: c.initial_tokens * c.token_units,
            stake_units: c.stake_tokens * c.token_units,
            security: rule.stakes(),
            quorum: config.quorum(),
            outlier_threshold_units: (c.outlier_threshold * c.weight_scale as f64).round() as i64,
            reward_weights: config.reward_weights(),
            genesis_weights,
            robust: match rule {
                Rule::Fedavg | Rule::Paper => None,
                rule => Some(RobustRule {
                    rule,
                    assumed_f: c.assumed_f,
                    threshold_gate: c.threshold_gate,
                }),
            },
            round_timeout_ms: (c.round_timeout_s * 1000.0).round() as u64,
            claim_bound: ClaimBound::from_config(config),
            options: c.options(),
            defence: match c.defence {
                Defence::None => None,
                defence if rule.stakes() => Some(defences::DefenceParams {
                    defence,
                    refund_percent: c.defence_refund_percent,
                }),
                // Without stakes there are no rewards to defend.
                _ => None,
            },
            preagg: if c.preaggregators.is_empty() {
                None
            } else {
                Some(preagg::PreaggParams {
                    stages: c.preaggregators.clone(),
                    assumed_f: c.assumed_f,
                    bucket_size: c.bucket_size,
                    clip_radius_units: (c.clip_radius * c.weight_scale as f64).round() as u64,
                })
            },
            engine: c.engine,
            block_gas_limit: c.block_gas_limit,
            buffered: buffered::BufferedParams::from_config(config),
            outlier: outlier::RelativeOutlier::from_config(config),
            rule_plugin: (rule == Rule::Plugin).then(|| {
                // The source registered last under the name; an unknown digest when none is,
                // which `check` refuses by name.
                rules::plugin::current(&c.rule_plugin).unwrap_or(rules::plugin::RuleId {
                    name: c.rule_plugin.clone(),
                    digest: String::new(),
                })
            }),
        }
    }

    /// A round's aggregate under these rules: the pre-aggregator chain, if any, then the rule
    /// (`inputs` the accepted submissions in chain order, `seed` bucketing's, see
    /// [`preagg::shuffle_seed`]). What the contract computes when a round closes, and what an
    /// attacker evaluates on the submissions its node holds.
    pub fn round_aggregate(
        &self,
        current: &[i64],
        inputs: &[rules::Input],
        seed: [u8; 32],
    ) -> rules::Aggregate {
        let (rule, f) = (self.rule(), self.assumed_f() as usize);
        if let Some(id) = &self.rule_plugin {
            // `check` keeps pre-aggregators away from plug-in rules.
            return rules::plugin::aggregate(id, current, inputs, f);
        }
        match &self.preagg {
            None => rule.aggregate(current, inputs, f, &self.options),
            Some(chain) => preagg::aggregate(rule, chain, current, inputs, f, &self.options, seed),
        }
    }

    /// The aggregation rule in force.
    pub fn rule(&self) -> Rule {
        match self.robust {
            Some(r) => r.rule,
            None if self.security => Rule::Paper,
            None => Rule::Fedavg,
        }
    }

    /// Whether the outlier threshold refuses submissions as they arrive: under the paper's
    /// rule, and under a robust rule behind `contract.threshold_gate`; the other rules judge
    /// a round's models together.
    pub fn threshold_applies(&self) -> bool {
        self.security
            && (self.rule().uses_threshold() || self.robust.is_some_and(|r| r.threshold_gate))
    }

    /// The assumed Byzantine count (0 for `fedavg` and `paper`, which ignore it).
    pub fn assumed_f(&self) -> u32 {
        self.robust.map_or(0, |r| r.assumed_f)
    }

    /// The units in existence: `robots * initial_units`, constant for a run.
    pub fn total_units(&self) -> u128 {
        u128::from(self.robots) * u128::from(self.initial_units)
    }

    /// N, the number of weights of the model.
    pub fn model_len(&self) -> usize {
        self.genesis_weights.len()
    }

    /// A distance in fixed-point units summed over the model's N weights, as the mean per
    /// weight in model units: the number `contract.outlier_threshold` is compared with, and
    /// the one `run`, `inspect` and `export` print.
    pub fn distance_per_weight(&self, distance_units: u64, weight_scale: u64) -> f64 {
        distance_units as f64 / (self.model_len() as f64 * weight_scale as f64)
    }

    /// The largest accepted distance `sum_i |w_i - w_a,i|`: `threshold_units * N`.
    pub fn max_distance_units(&self) -> u128 {
        // The product fits u128: threshold below 2^63, at most 2^16 weights.
        u128::try_from(self.outlier_threshold_units).unwrap_or(0) * self.model_len() as u128
    }

    /// Asserts what the contract relies on; these come from a validated config, so a failure is
    /// a bug, not an input error.
    fn assert_valid(&self) {
        if let Err(e) = self.check() {
            panic!("invalid contract parameters: {e}");
        }
    }

    /// Checks what the contract relies on (quorum, reward weights, supply, model size).
    pub fn check(&self) -> Result<(), String> {
        if self.quorum < 1 {
            return Err("quorum must be at least 1".into());
        }
        if self.quorum > self.robots {
            return Err(format!(
                "quorum {} exceeds robots {}",
                self.quorum, self.robots
            ));
        }
        if self.reward_weights.len() != self.quorum as usize {
            return Err("one reward weight per rank".into());
        }
        if let Some(r) = self.robust {
            if matches!(r.rule, Rule::Fedavg | Rule::Paper) || !self.security {
                return Err(format!(
                    "{} is not a robust rule with stakes",
                    r.rule.name()
                ));
            }
            let needed = r.rule.min_quorum(r.assumed_f);
            if self.quorum < needed {
                return Err(format!(
                    "{} with assumed_f {} needs a quorum of at least {needed}, got {}",
                    r.rule.name(),
                    r.assumed_f,
                    self.quorum
                ));
            }
            if r.rule == Rule::Mda
                && crate::config::mda_subsets(u64::from(self.quorum), u64::from(r.assumed_f))
                    .is_none()
            {
                return Err(format!(
                    "mda with quorum {} and assumed_f {} searches more than {} subsets",
                    self.quorum,
                    r.assumed_f,
                    crate::config::MDA_MAX_SUBSETS
                ));
            }
        }
        match (&self.rule_plugin, self.rule() == Rule::Plugin) {
            (Some(id), true) if !rules::plugin::is_registered(id) => {
                let digest = (!id.digest.is_empty()).then_some(id.digest.as_str());
                return Err(rules::plugin::missing(&id.name, digest));
            }
            (Some(_), true) if self.preagg.is_some() => {
                return Err("a plug-in rule takes no pre-aggregators".into());
            }
            (Some(_), false) | (None, true) => {
                return Err("a plug-in rule and its id go together".into());
            }
            _ => {}
        }
        if let Some(d) = self.defence {
            if d.defence == Defence::None || d.refund_percent > 100 || !self.security {
                return Err(format!(
                    "defence {} with refund {} % needs a staking rule and a percentage",
                    d.defence.name(),
                    d.refund_percent
                ));
            }
        }
        if let Some(chain) = &self.preagg {
            chain.check(self.rule(), self.assumed_f(), self.quorum)?;
            if !self.security || self.engine == ContractEngine::Evm {
                return Err("pre-aggregators need a staking rule and the native engine".into());
            }
        }
        if let Some(b) = &self.buffered {
            b.check()?;
            if self.engine == ContractEngine::Evm {
                return Err("the buffered protocol needs the native engine".into());
            }
        }
        if let Some(r) = &self.outlier {
            r.check(self.outlier_threshold_units)?;
            if self.buffered.is_none()
                || !self.security
                || !self.rule().uses_threshold()
                || self.engine == ContractEngine::Evm
            {
                return Err(
                    "the relative outlier rule needs the buffered protocol, the paper's rule \
                     and the native engine"
                        .into(),
                );
            }
        }
        if !self.reward_weights.iter().any(|&k| k > 0) {
            return Err("at least one rewarded rank".into());
        }
        if !(1..=MAX_SAMPLES).contains(&self.claim_bound.max_samples) {
            return Err(format!(
                "claim bound {} outside 1..={MAX_SAMPLES}",
                self.claim_bound.max_samples
            ));
        }
        if self.total_units() > u128::from(u64::MAX / 4) {
            return Err("token supply must fit in 2^62".into());
        }
        let n = self.genesis_weights.len();
        if !(1..=MAX_MODEL_LEN).contains(&n) {
            return Err(format!("model length {n} outside 1..=2^16"));
        }
        if !self
            .genesis_weights
            .iter()
            .all(|w| w.unsigned_abs() < MAX_WEIGHT_MAGNITUDE)
        {
            return Err("genesis weights must fit int48".into());
        }
        Ok(())
    }
}

/// The contract's state after some block: cheap to clone (weights and history are `Arc`s).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContractState {
    /// Token balance of every account, in units.
    pub balances: Vec<u64>,
    /// Units held by the contract itself (pool plus carried remainders).
    pub holdings_units: u64,
    /// Aggregation round (the model's version).
    pub round: u64,
    /// The shared model, fixed point.
    pub weights: Arc<[i64]>,
    /// blake3 of `weights` (kept in step by the contract).
    pub weights_digest: Digest,
    /// The shared model before the last aggregation, w(t-1); `None` in round 0.
    pub previous_weights: Option<Arc<[i64]>>,
    /// blake3 of `previous_weights` (all zero bytes while it is `None`).
    pub previous_digest: Digest,
    /// This round's counted submissions (accepted and outliers), in submission order.
    pub submissions: Vec<Submission>,
    /// The last aggregated round, with its payouts; `None` before the first aggregation.
    pub last_round: Option<Arc<RoundSummary>>,
    /// Timestamp of the block being executed, ms (set by [`ContractState::enter_block`]).
    #[serde(default)]
    pub block_time_ms: u64,
    /// When the open round opened (block time of the last aggregation or deadline), ms.
    #[serde(default)]
    pub round_opened_ms: u64,
    /// Rounds closed by the deadline without aggregation.
    #[serde(default)]
    pub rounds_timed_out: u64,
    /// Stake units refunded by deadlines, in all.
    #[serde(default)]
    pub timeout_refunded_units: u64,
    /// With `contract.engine = "evm"`: the EVM holding the deployed contract, whose storage is
    /// the truth the fields above are read back from. Not serialised (the fields above are the
    /// state's portable form) and not in [`ContractState::digest`] (they mirror it exactly).
    #[serde(skip)]
    pub evm: Option<Arc<evm::EvmState>>,
    /// The buffered protocol's state ([`buffered`]); `None` under rounds, and then in neither
    /// the encoding nor the digest.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub buffered: Option<Arc<buffered::BufferState>>,
}

impl ContractState {
    /// The state at genesis.
    pub fn genesis(params: &ContractParams) -> ContractState {
        params.assert_valid();
        ContractState {
            balances: vec![params.initial_units; params.robots as usize],
            holdings_units: 0,
            round: 0,
            weights: params.genesis_weights.clone(),
            weights_digest: model_digest(&params.genesis_weights),
            previous_weights: None,
            previous_digest: Digest::default(),
            submissions: Vec::new(),
            last_round: None,
            block_time_ms: 0,
            round_opened_ms: 0,
            rounds_timed_out: 0,
            timeout_refunded_units: 0,
            evm: match params.engine {
                ContractEngine::Native => None,
                ContractEngine::Evm => Some(Arc::new(evm::EvmState::deploy(params))),
            },
            buffered: params
                .buffered
                .as_ref()
                .map(|_| Arc::new(buffered::BufferState::genesis(params.robots))),
        }
    }

    /// `getModel()`: the shared model and its round (version).
    pub fn get_model(&self) -> (Arc<[i64]>, u64) {
        (self.weights.clone(), self.round)
    }

    /// Accepted submissions in the current round.
    pub fn accepted_count(&self) -> u32 {
        self.submissions
            .iter()
            .filter(|s| s.verdict == Verdict::Accepted)
            .count() as u32
    }

    /// The current round's accepted models with their sample counts, in submission order.
    pub fn accepted_models(&self) -> Vec<(&[i64], u64)> {
        self.submissions
            .iter()
            .filter(|s| s.verdict == Verdict::Accepted)
            .map(|s| (&s.weights[..], s.samples))
            .collect()
    }

    /// True when `robot` has a counted submission in the current round (under the buffered
    /// protocol: against the newest version).
    pub fn has_submitted(&self, robot: RobotId) -> bool {
        if let Some(b) = &self.buffered {
            return b.last_base.get(robot as usize) > Some(&self.round);
        }
        self.submissions.iter().any(|s| s.sender == robot)
    }

    /// Executes one call sent by `sender` with `value_units` attached. Never panics on the
    /// call's contents; asserts token conservation afterwards.
    pub fn execute(
        &mut self,
        params: &ContractParams,
        sender: RobotId,
        value_units: u64,
        call: &Call,
    ) -> Outcome {
        self.execute_with_gas(params, sender, value_units, call, None)
    }

    /// [`ContractState::execute`] with the transaction's own gas limit, when it carries one
    /// ([`gas_limit::TxGas`]): the `evm` engine runs the call with it (out of gas it
    /// reverts, [`Outcome::OutOfGas`]); without one the block's limit applies. The native
    /// engine has no gas and ignores it.
    pub fn execute_with_gas(
        &mut self,
        params: &ContractParams,
        sender: RobotId,
        value_units: u64,
        call: &Call,
        gas_limit: Option<u64>,
    ) -> Outcome {
        assert_eq!(
            self.balances.len(),
            params.robots as usize,
            "state and params disagree"
        );
        let outcome = match (params.engine, call) {
            (ContractEngine::Evm, call) => {
                evm::execute(self, params, sender, value_units, call, gas_limit)
            }
            (ContractEngine::Native, Call::SubmitModel { .. }) if params.buffered.is_some() => {
                Outcome::Malformed(
                    "the buffered protocol takes submitUpdate naming the base".into(),
                )
            }
            (ContractEngine::Native, Call::SubmitModel { weights, samples }) => {
                self.submit_model(params, sender, value_units, weights, *samples)
            }
            (
                ContractEngine::Native,
                Call::SubmitUpdate {
                    weights,
                    samples,
                    base_round,
                    base_digest,
                },
            ) => self.submit_update(
                params,
                sender,
                value_units,
                weights,
                *samples,
                *base_round,
                base_digest,
            ),
            (ContractEngine::Native, Call::Transfer { to, amount_units }) => {
                self.transfer(sender, value_units, *to, *amount_units)
            }
        };
        assert_eq!(
            self.total_units(),
            params.total_units(),
            "token conservation broken by {} from {sender}",
            outcome.name()
        );
        outcome
    }

    /// Restarts the open round when the contract's rules change under it: every counted
    /// submission of the round gets its stake back from the contract and may submit again;
    /// the round number, the model and the carried remainder stay. Conserves tokens.
    pub fn restart_round(&mut self) {
        if self.evm.is_some() {
            return evm::restart_round(self);
        }
        self.refund_open_round(|_| true);
    }

    /// Sum of all balances plus the contract's holdings: constant for a run.
    pub fn total_units(&self) -> u128 {
        self.balances.iter().map(|&b| u128::from(b)).sum::<u128>() + u128::from(self.holdings_units)
    }

    /// A digest of the whole state: a compact encoding with model digests in place of models.
    pub fn digest(&self) -> Digest {
        let mut h = blake3::Hasher::new();
        h.update(b"swarmfl contract state v1");
        h.update(&(self.balances.len() as u64).to_le_bytes());
        for b in &self.balances {
            h.update(&b.to_le_bytes());
        }
        h.update(&self.holdings_units.to_le_bytes());
        h.update(&self.round.to_le_bytes());
        h.update(&self.weights_digest.0);
        h.update(&[u8::from(self.previous_weights.is_some())])
            .update(&self.previous_digest.0);
        hash_submissions(&mut h, &self.submissions);
        match &self.last_round {
            Some(r) => {
                h.update(&[1]).update(&r.round.to_le_bytes());
                hash_submissions(&mut h, &r.submissions);
                h.update(&(r.payouts.len() as u64).to_le_bytes());
                for p in &r.payouts {
                    h.update(&p.robot.to_le_bytes())
                        .update(&p.rank.to_le_bytes());
                    h.update(&p.reward_weight.to_le_bytes())
                        .update(&p.units.to_le_bytes());
                }
                h.update(&r.pool_units.to_le_bytes())
                    .update(&r.carried_units.to_le_bytes());
            }
            None => {
                h.update(&[0]);
            }
        }
        h.update(&self.block_time_ms.to_le_bytes())
            .update(&self.round_opened_ms.to_le_bytes())
            .update(&self.rounds_timed_out.to_le_bytes())
            .update(&self.timeout_refunded_units.to_le_bytes());
        if let Some(b) = &self.buffered {
            b.hash(&mut h);
        }
        Digest::from(h.finalize())
    }

    fn transfer(&mut self, sender: RobotId, value_units: u64, to: RobotId, amount: u64) -> Outcome {
        let accounts = self.balances.len();
        if sender as usize >= accounts || to as usize >= accounts {
            return Outcome::Malformed(format!(
                "transfer from {sender} to {to}: accounts are 0..{accounts}"
            ));
        }
        if value_units != 0 {
            return Outcome::Malformed(format!(
                "transfer carries value {value_units}; send the amount in the call, value 0"
            ));
        }
        let from_balance = self.balances[sender as usize];
        if from_balance < amount {
            return Outcome::InsufficientFunds;
        }
        self.balances[sender as usize] = from_balance - amount;
        let to_balance = &mut self.balances[to as usize];
        *to_balance = to_balance
            .checked_add(amount)
            .expect("conserved supply fits u64");
        Outcome::Transferred
    }

    fn submit_model(
        &mut self,
        params: &ContractParams,
        sender: RobotId,
        value_units: u64,
        weights: &Arc<[i64]>,
        samples: u64,
    ) -> Outcome {
        let Some(&balance) = self.balances.get(sender as usize) else {
            return Outcome::Malformed(format!(
                "submission from {sender}: accounts are 0..{}",
                self.balances.len()
            ));
        };
        if self.has_submitted(sender) {
            return Outcome::Duplicate;
        }
        if let Err(reason) = check_model(params, weights, samples) {
            return Outcome::Malformed(reason);
        }
        let stake_units = match submit::stake(params, value_units, balance) {
            Ok(units) => units,
            Err(refused) => return refused,
        };

        let distance_units = payout::distance_units(weights, &self.weights);
        let verdict = submit::verdict(params, distance_units, params.max_distance_units());
        if verdict == Verdict::Accepted && params.options.int48_products {
            if let Err(reason) = payout::int48_products(&self.accepted_models(), weights, samples) {
                return Outcome::Malformed(reason);
            }
        }
        self.take_stake_and_record(
            sender,
            samples,
            distance_units,
            stake_units,
            verdict,
            weights,
        );
        let round = self.round;
        self.conclude(params, round, distance_units, verdict, |state| {
            state.aggregate(params)
        })
    }

    /// Closes the round: FedAvg, ranking and payouts, round += 1. Returns the payouts.
    fn aggregate(&mut self, params: &ContractParams) -> Vec<Payout> {
        let submissions = std::mem::take(&mut self.submissions);
        let accepted: Vec<&Submission> = submissions
            .iter()
            .filter(|s| s.verdict == Verdict::Accepted)
            .collect();
        assert_eq!(accepted.len(), params.quorum as usize);

        let inputs: Vec<rules::Input> = accepted
            .iter()
            .map(|s| rules::Input {
                weights: &s.weights,
                samples: s.samples,
                distance_units: s.distance_units,
            })
            .collect();
        let seed = match params.preagg {
            // Only bucketing reads it; computed only when a chain can.
            Some(_) => {
                let accepted: Vec<(RobotId, Digest)> = accepted
                    .iter()
                    .map(|s| (s.sender, s.weights_digest))
                    .collect();
                preagg::shuffle_seed(self.round, &self.weights_digest, &accepted)
            }
            None => [0; 32],
        };
        let aggregate = params.round_aggregate(&self.weights, &inputs, seed);
        let new_weights: Arc<[i64]> = aggregate.weights.into();
        assert_eq!(new_weights.len(), self.weights.len());

        let models: Vec<&[i64]> = accepted.iter().map(|s| &s.weights[..]).collect();
        let (payouts, pool_units) =
            self.settle(params, &submissions, &accepted, &models, &aggregate.used);

        self.previous_weights = Some(std::mem::replace(&mut self.weights, new_weights));
        self.previous_digest = self.weights_digest;
        self.weights_digest = model_digest(&self.weights);
        let summary = RoundSummary {
            round: self.round,
            submissions,
            payouts: payouts.clone(),
            pool_units,
            carried_units: self.holdings_units,
        };
        self.last_round = Some(Arc::new(summary));
        self.round += 1;
        self.round_opened_ms = self.block_time_ms;
        payouts
    }
}

/// blake3 of a model's little-endian weights.
pub fn model_digest(weights: &[i64]) -> Digest {
    let mut bytes = Vec::with_capacity(weights.len() * 8);
    for w in weights {
        bytes.extend_from_slice(&w.to_le_bytes());
    }
    Digest::of(&bytes)
}

fn hash_submissions(h: &mut blake3::Hasher, submissions: &[Submission]) {
    h.update(&(submissions.len() as u64).to_le_bytes());
    for s in submissions {
        h.update(&s.sender.to_le_bytes())
            .update(&s.samples.to_le_bytes());
        h.update(&s.distance_units.to_le_bytes())
            .update(&s.stake_units.to_le_bytes());
        h.update(&[s.verdict as u8]).update(&s.weights_digest.0);
    }
}

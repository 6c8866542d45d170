//! What the robots measured (reduced from [`LearnReport`] events) and the run's figures derived
//! from the final canonical chain: the paper's average loss per round, the shared model's loss
//! on the held-out set, submissions by outcome, and tokens gained per group (docs/SPEC.md section 6).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::config::Config;
use crate::contract::{Call, Outcome};
use crate::learn::{self, ModelShape, TrainData};
use crate::ledger::{BlockEntry, Ledger, TxHash};
use crate::types::{Digest, RobotId, SimTime};

/// What a robot did in one learning phase. Logged as an event because only the robot knows it:
/// the trained model itself travels in the transaction that follows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LearnReport {
    /// The robot.
    pub robot: RobotId,
    /// The aggregation round of the shared model it started from (its own chain's view).
    pub base_round: u64,
    /// What it did.
    pub action: LearnAction,
}

/// The outcome of a learning phase.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum LearnAction {
    /// An honest robot trained and submits the model in transaction `tx`.
    Trained {
        /// The submission.
        tx: TxHash,
        /// Training samples (the n it claims).
        train_samples: u32,
        /// Validation samples.
        val_samples: u32,
        /// Validation loss of its trained model (NaN if it had no validation split).
        val_loss: f64,
        /// Training loss of the last epoch.
        final_train_loss: f64,
    },
    /// A Byzantine robot forged a model and submits it in transaction `tx`.
    Forged {
        /// The submission.
        tx: TxHash,
        /// Samples it claims.
        claimed_samples: u32,
    },
    /// The robot did not submit this period.
    Skipped {
        /// Why.
        reason: SkipReason,
    },
}

/// Why a robot did not submit in a learning phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum SkipReason {
    /// Fewer training samples than `learn.min_train_samples`.
    NotEnoughData,
    /// Its balance (in its own view) is below the stake: it can no longer take part.
    InsufficientStake,
    /// It already submitted in the current round (in its own view).
    AlreadySubmitted,
    /// Training produced weights that are not finite or do not fit the fixed point.
    NonFiniteModel,
    /// A Byzantine robot's attack waited (e.g. for honest models of the round) until its next
    /// phase was due.
    Waited,
    /// The robot is crashed (a fault): it neither trains nor submits.
    Crashed,
    /// Its node's gas estimate failed (`contract.gas_limit = "estimate"`: on the estimated
    /// state the contract refuses the call, e.g. a second submission in the round): web3.py
    /// raises and the authors' controller sends nothing.
    EstimateFailed,
}

impl SkipReason {
    /// A stable name for summaries.
    pub fn name(self) -> &'static str {
        match self {
            SkipReason::NotEnoughData => "not_enough_data",
            SkipReason::InsufficientStake => "insufficient_stake",
            SkipReason::AlreadySubmitted => "already_submitted",
            SkipReason::NonFiniteModel => "non_finite_model",
            SkipReason::Waited => "waited",
            SkipReason::Crashed => "crashed",
            SkipReason::EstimateFailed => "estimate_failed",
        }
    }
}

/// One honest training, as recorded.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainRecord {
    /// The robot.
    pub robot: RobotId,
    /// When it trained.
    pub time: SimTime,
    /// Round of its start model.
    pub base_round: u64,
    /// Training samples.
    pub train_samples: u32,
    /// Validation loss.
    pub val_loss: f64,
}

/// The reduced measurements: every learning phase, folded.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Honest trainings by their submission.
    pub trained: BTreeMap<TxHash, TrainRecord>,
    /// Forged submissions by Byzantine robots.
    pub forged: u64,
    /// Skipped learning phases by reason.
    pub skipped: BTreeMap<SkipReason, u64>,
    digest: Digest,
}

impl Metrics {
    /// Folds one report (the metrics reducer).
    pub fn apply(&mut self, time: SimTime, report: &LearnReport) {
        let bytes = rmp_serde::to_vec(&(time, report)).expect("reports encode");
        let mut h = blake3::Hasher::new();
        h.update(&self.digest.0);
        h.update(&bytes);
        self.digest = h.finalize().into();
        match &report.action {
            LearnAction::Trained {
                tx,
                train_samples,
                val_loss,
                ..
            } => {
                self.trained.insert(
                    *tx,
                    TrainRecord {
                        robot: report.robot,
                        time,
                        base_round: report.base_round,
                        train_samples: *train_samples,
                        val_loss: *val_loss,
                    },
                );
            }
            LearnAction::Forged { .. } => self.forged += 1,
            LearnAction::Skipped { reason } => *self.skipped.entry(*reason).or_insert(0) += 1,
        }
    }

    /// A running digest of every report folded so far.
    pub fn digest(&self) -> Digest {
        self.digest
    }
}

/// Numbers written by serde_json, which writes NaN (a round without honest models) and the
/// infinities as `null`: `null` reads back as NaN, so a summary reads back as written.
pub fn nans_from_nulls<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    let v = Vec::<Option<f64>>::deserialize(d)?;
    Ok(v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
}

/// [`nans_from_nulls`] for one number.
pub fn nan_from_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// The contract section of `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContractSummary {
    /// Aggregation rounds completed on the final canonical chain.
    pub rounds: u64,
    /// Simulated time of the block that closed round r (index r - 1).
    #[serde(deserialize_with = "nans_from_nulls")]
    pub round_times_s: Vec<f64>,
    /// The paper's metric: sample-weighted mean validation loss of the honest models aggregated
    /// in round r (Byzantine models have no validation loss; NaN if a round had only those).
    #[serde(deserialize_with = "nans_from_nulls")]
    pub loss_by_round: Vec<f64>,
    /// Loss of the shared model after round r on the fixed held-out set.
    #[serde(deserialize_with = "nans_from_nulls")]
    pub heldout_loss_by_round: Vec<f64>,
    /// Loss of the genesis model on the held-out set.
    #[serde(deserialize_with = "nan_from_null")]
    pub heldout_loss_initial: f64,
    /// Last entry of `loss_by_round` (None without a round).
    pub final_loss: Option<f64>,
    /// Last entry of `heldout_loss_by_round`.
    pub final_heldout_loss: Option<f64>,
    /// The paper's pilot-study figure: the mean absolute distance `(1/N) sum_i |w_i - w_a,i|`
    /// between an honest robot's accepted submission and the shared model the contract held
    /// when it executed it, averaged over every accepted honest submission of the final
    /// canonical chain (the paper measured about 0.01 and set the outlier threshold at 5x
    /// that, 0.05). `None` without an accepted honest submission.
    #[serde(default)]
    pub mean_honest_distance: Option<f64>,
    /// The outlier threshold the distances are compared with (`contract.outlier_threshold`).
    #[serde(default)]
    pub outlier_threshold: f64,
    /// The same mean over the accepted honest submissions of round r (index r - 1); NaN for a
    /// round that aggregated Byzantine models only.
    #[serde(default, deserialize_with = "nans_from_nulls")]
    pub mean_honest_distance_by_round: Vec<f64>,
    /// Under the relative outlier rule (`contract.outlier_rule = "relative"`,
    /// `contract/outlier.rs`): the bound in force, as a mean absolute distance per weight, at
    /// the end of the block that closed version r (index r - 1). Empty under the absolute
    /// rule, and then left out.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "nans_from_nulls"
    )]
    pub outlier_bound_by_round: Vec<f64>,
    /// Under the relative outlier rule: the honest robots' submissions judged outliers on the
    /// final canonical chain (`submissions.outlier` counts everyone's). `None` under the
    /// absolute rule, and then left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub honest_outliers: Option<u64>,
    /// The claim bound the contract enforced: the most samples a submission could claim
    /// (`contract.max_claimed_samples`, derived from the data window when 0; a larger claim is
    /// counted under `submissions.malformed`). `None` without a contract (baselines).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_claimed_samples: Option<u64>,
    /// Rounds closed by the deadline (`contract.round_timeout_s`) along the final canonical
    /// chain (its head's count).
    #[serde(default)]
    pub rounds_timed_out: u64,
    /// `submitModel` transactions on the final canonical chain by outcome.
    pub submissions: BTreeMap<String, u64>,
    /// Honest models aggregated, Byzantine models aggregated.
    pub aggregated_honest: u64,
    /// Byzantine models aggregated.
    pub aggregated_byzantine: u64,
    /// Rounds whose accepted submissions were more than half Byzantine (4 or more of the
    /// paper's 7): the round majorities RESEARCH.md counts. Divide by `rounds` for the rate.
    /// `None` without Byzantine robots, or without a chain (baselines), and in summaries made
    /// before the field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub byzantine_majority_rounds: Option<u64>,
    /// Learning phases skipped, by reason (from the robots' reports).
    pub skipped: BTreeMap<String, u64>,
    /// The median of the shared model's held-out loss over the last [`LAST_WINDOW_S`] of the
    /// run, sampled every [`LAST_SAMPLE_S`] (the loss of the version in force at each sample;
    /// less noisy than the final value). Absent in summaries made before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub median_heldout_loss_last_1000s: Option<f64>,
    /// The age of the accepted updates' bases (buffered protocol and matched ideal). Absent
    /// under the paper's rounds and in summaries made before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub staleness: Option<Staleness>,
}

/// The window of [`ContractSummary::median_heldout_loss_last_1000s`], in simulated seconds.
pub const LAST_WINDOW_S: f64 = 1000.0;

/// The sampling step of that median, in simulated seconds.
pub const LAST_SAMPLE_S: f64 = 10.0;

/// The age of the base of every accepted (counted and not refused) update.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Staleness {
    /// Accepted updates by the age of their base in versions (index = versions behind the
    /// newest when the update was executed).
    pub age_versions: Vec<u64>,
    /// The age of their base in seconds: from the base version's creation (the block that
    /// made it, genesis at 0 s) to the update's execution.
    pub age_s: crate::ledger::metrics::DelayStats,
    /// Submissions refused as stale (`contract.max_staleness`).
    pub stale_refusals: u64,
}

impl Staleness {
    /// The section of `ages` (versions, milliseconds) and `stale_refusals`.
    pub fn of(ages: &[(u64, u64)], stale_refusals: u64) -> Staleness {
        let mut age_versions = Vec::new();
        for &(v, _) in ages {
            let v = v as usize;
            if age_versions.len() <= v {
                age_versions.resize(v + 1, 0);
            }
            age_versions[v] += 1;
        }
        Staleness {
            age_versions,
            age_s: crate::ledger::metrics::DelayStats::of(ages.iter().map(|a| a.1).collect()),
            stale_refusals,
        }
    }
}

/// The median held-out loss over the last [`LAST_WINDOW_S`] of a run of `end_s` seconds whose
/// shared model starts at loss `initial` and becomes version r (loss `losses[r - 1]`) at
/// `times_s[r - 1]`: sampled every [`LAST_SAMPLE_S`] from `end_s - LAST_WINDOW_S` (or 0) to
/// `end_s`, the version in force at each sample (lower median). NaN losses are skipped; None
/// when none is left.
pub fn median_last_window(
    times_s: &[f64],
    losses: &[f64],
    initial: f64,
    end_s: f64,
) -> Option<f64> {
    let start = (end_s - LAST_WINDOW_S).max(0.0);
    let steps = ((end_s - start) / LAST_SAMPLE_S).floor() as usize;
    let mut values: Vec<f64> = (0..=steps)
        .map(|k| {
            let t = start + k as f64 * LAST_SAMPLE_S;
            let in_force = times_s.partition_point(|&x| x <= t);
            if in_force == 0 {
                initial
            } else {
                losses.get(in_force - 1).copied().unwrap_or(f64::NAN)
            }
        })
        .filter(|v| v.is_finite())
        .collect();
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    Some(values[(values.len() - 1) / 2])
}

/// The tokens section of `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TokenSummary {
    /// Sum of balances and contract holdings at genesis, in units.
    pub total_units_start: u128,
    /// The same at the final canonical head (equal: conservation).
    pub total_units_end: u128,
    /// Mean over honest robots of (final balance - initial) in tokens.
    pub honest_mean_gain: Option<f64>,
    /// Mean over Byzantine robots of the same.
    pub byzantine_mean_gain: Option<f64>,
    /// Final balance of every robot, in tokens.
    pub balances: Vec<f64>,
    /// Units held by the contract (pool and carried remainders), in tokens.
    pub contract_holdings: f64,
    /// The first block of the final canonical chain at which the Byzantine robots hold more
    /// than `byzantine.switch_token_share` of the robots' balances (the moment
    /// `smart-then-collude` switches, as read from that chain); `None` if never, or without
    /// Byzantine robots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub byzantine_control: Option<ControlPoint>,
}

/// A block at which the Byzantine robots took control of the tokens (see
/// [`TokenSummary::byzantine_control`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ControlPoint {
    /// The block's height.
    pub height: u64,
    /// Its timestamp, simulated s.
    pub time_s: f64,
    /// The Byzantine share of the balances after it.
    pub share: f64,
    /// Held-out loss of the shared model after it (compare with `final_heldout_loss`).
    #[serde(deserialize_with = "nan_from_null")]
    pub heldout_loss: f64,
}

/// The Byzantine share of the robots' balances, `byzantine / all` in `[0, 1]` (0 when nobody
/// holds anything); `byzantine[i]` marks robot i.
pub fn byzantine_share(balances: &[u64], byzantine: &[bool]) -> f64 {
    let (mut ours, mut all) = (0u128, 0u128);
    for (robot, &balance) in balances.iter().enumerate() {
        all += u128::from(balance);
        if byzantine.get(robot).copied().unwrap_or(false) {
            ours += u128::from(balance);
        }
    }
    if all == 0 {
        0.0
    } else {
        ours as f64 / all as f64
    }
}

/// The node whose head ends the final canonical chain: greatest total difficulty, ties to the
/// lowest id.
pub fn best_node(ledger: &Ledger) -> RobotId {
    (0..ledger.robots())
        .max_by_key(|&r| {
            let (hash, _) = ledger.head(r);
            let td = ledger.block(&hash).map_or(0, |e| e.total_difficulty);
            (td, std::cmp::Reverse(r))
        })
        .expect("a swarm has at least one robot")
}

/// The held-out loss of on-chain (fixed-point) weights: the mean squared error of the model
/// they encode over the run's held-out set, NaN when that set is empty.
pub(crate) struct HeldoutLoss {
    shape: ModelShape,
    scale: u64,
    data: Option<TrainData>,
}

impl HeldoutLoss {
    /// The evaluator of `heldout` under `config`'s model and weight scale.
    pub(crate) fn new(config: &Config, heldout: &[crate::data::Sample]) -> HeldoutLoss {
        let shape = ModelShape::from_config(config);
        let data = TrainData::new(&shape, heldout)
            .ok()
            .filter(|d| !d.is_empty());
        HeldoutLoss {
            shape,
            scale: config.contract.weight_scale,
            data,
        }
    }

    /// The held-out loss of `weights` (fixed point).
    pub(crate) fn of(&self, weights: &[i64]) -> f64 {
        match &self.data {
            Some(data) => learn::loss(&self.shape, &learn::from_fixed(weights, self.scale), data),
            None => f64::NAN,
        }
    }
}

/// Computes the contract and token sections from the final canonical chain.
pub fn summarise(
    config: &Config,
    ledger: &Ledger,
    metrics: &Metrics,
    heldout: &[crate::data::Sample],
    byzantine: &[bool],
) -> (ContractSummary, TokenSummary) {
    let heldout = HeldoutLoss::new(config, heldout);
    let best = best_node(ledger);
    let mut walk = ChainWalk::new(config, ledger, metrics, &heldout, byzantine, best);
    let mut control: Option<ControlPoint> = None;
    let any_byzantine = byzantine.iter().any(|&b| b);
    for hash in ledger.canonical_chain(best) {
        let entry = ledger.block(hash).expect("canonical blocks are stored");
        if any_byzantine && control.is_none() {
            control = control_point(config, entry, byzantine, &heldout);
        }
        for (tx_hash, outcome) in entry.block.txs.iter().zip(entry.receipts.iter()) {
            walk.receipt(entry, tx_hash, outcome);
        }
    }
    let contract = walk.finish();
    let tokens = token_summary(config, ledger, best, byzantine, control);
    (contract, tokens)
}

/// The block `entry` as the moment the Byzantine robots took control of the tokens, if their
/// share of the balances after it is above `byzantine.switch_token_share`.
fn control_point(
    config: &Config,
    entry: &BlockEntry,
    byzantine: &[bool],
    heldout: &HeldoutLoss,
) -> Option<ControlPoint> {
    let share = byzantine_share(&entry.state.balances, byzantine);
    (share > config.byzantine.switch_token_share).then(|| ControlPoint {
        height: entry.block.header.height,
        time_s: entry.block.header.timestamp_ms as f64 / 1000.0,
        share,
        heldout_loss: heldout.of(&entry.state.weights),
    })
}

/// The contract section, folded receipt by receipt along the final canonical chain.
struct ChainWalk<'a> {
    ledger: &'a Ledger,
    metrics: &'a Metrics,
    heldout: &'a HeldoutLoss,
    byzantine: &'a [bool],
    scale: u64,
    /// The section so far.
    summary: ContractSummary,
    /// Sum and count of the accepted honest submissions' distances, over the whole chain.
    honest_distance_sum: f64,
    honest_accepted: u64,
    /// The same within the round under way.
    round_distance_sum: f64,
    round_honest: u64,
    /// The accepted submissions of the round under way.
    round_txs: Vec<TxHash>,
    /// (versions, ms) of each accepted update's base (buffered protocol).
    ages: Vec<(u64, u64)>,
    end_s: f64,
}

impl<'a> ChainWalk<'a> {
    /// A walk that has seen no block yet: the figures known before the first one (the genesis
    /// model's held-out loss, the contract's parameters, the robots' skipped phases).
    fn new(
        config: &Config,
        ledger: &'a Ledger,
        metrics: &'a Metrics,
        heldout: &'a HeldoutLoss,
        byzantine: &'a [bool],
        best: RobotId,
    ) -> ChainWalk<'a> {
        let s = ContractSummary {
            rounds: 0,
            round_times_s: vec![],
            loss_by_round: vec![],
            heldout_loss_by_round: vec![],
            heldout_loss_initial: heldout.of(&ledger.params().genesis_weights),
            final_loss: None,
            final_heldout_loss: None,
            mean_honest_distance: None,
            outlier_threshold: config.contract.outlier_threshold,
            mean_honest_distance_by_round: vec![],
            outlier_bound_by_round: vec![],
            honest_outliers: ledger.params().outlier.map(|_| 0),
            max_claimed_samples: Some(ledger.params().claim_bound.max_samples),
            rounds_timed_out: ledger.head_state(best).rounds_timed_out,
            submissions: BTreeMap::new(),
            aggregated_honest: 0,
            aggregated_byzantine: 0,
            byzantine_majority_rounds: byzantine.iter().any(|&b| b).then_some(0),
            skipped: metrics
                .skipped
                .iter()
                .map(|(k, v)| (k.name().to_string(), *v))
                .collect(),
            median_heldout_loss_last_1000s: None,
            staleness: None,
        };
        ChainWalk {
            ledger,
            metrics,
            heldout,
            byzantine,
            scale: config.contract.weight_scale,
            summary: s,
            honest_distance_sum: 0.0,
            honest_accepted: 0,
            round_distance_sum: 0.0,
            round_honest: 0,
            round_txs: Vec::new(),
            ages: Vec::new(),
            end_s: config.run.duration_s,
        }
    }

    /// Folds the receipt of transaction `tx_hash` in block `entry`; only model submissions
    /// count.
    fn receipt(&mut self, entry: &BlockEntry, tx_hash: &TxHash, outcome: &Outcome) {
        let Some(submitted) = self.ledger.tx(tx_hash).filter(|t| {
            matches!(
                t.tx.call,
                Call::SubmitModel { .. } | Call::SubmitUpdate { .. }
            )
        }) else {
            return;
        };
        let s = &mut self.summary;
        *s.submissions.entry(outcome.name().to_string()).or_insert(0) += 1;
        if outcome.is_accepted() {
            self.round_txs.push(*tx_hash);
            if let Call::SubmitUpdate { base_round, .. } = submitted.tx.call {
                // The version at execution: the rounds closed before this receipt.
                let behind = s.rounds.saturating_sub(base_round);
                let made_ms = match base_round {
                    0 => 0.0,
                    r => s.round_times_s.get(r as usize - 1).copied().unwrap_or(0.0) * 1000.0,
                };
                let at_ms = entry.block.header.timestamp_ms as f64;
                self.ages
                    .push((behind, (at_ms - made_ms).max(0.0).round() as u64));
            }
        }
        let honest = !self
            .byzantine
            .get(submitted.tx.sender as usize)
            .copied()
            .unwrap_or(false);
        if let (true, Outcome::Outlier { .. }, Some(n)) =
            (honest, outcome, s.honest_outliers.as_mut())
        {
            *n += 1;
        }
        if let (true, Outcome::Accepted { distance_units, .. })
        | (true, Outcome::Aggregated { distance_units, .. }) = (honest, outcome)
        {
            let d = self
                .ledger
                .params()
                .distance_per_weight(*distance_units, self.scale);
            self.honest_distance_sum += d;
            self.honest_accepted += 1;
            self.round_distance_sum += d;
            self.round_honest += 1;
        }
        if let Outcome::Aggregated { .. } = outcome {
            self.close_round(entry);
        }
    }

    /// Block `entry` aggregated a round: its paper loss (over the honest models aggregated),
    /// held-out loss, mean honest distance and outlier bound.
    fn close_round(&mut self, entry: &BlockEntry) {
        let byzantine = self
            .round_txs
            .iter()
            .filter_map(|hash| self.ledger.tx(hash))
            .filter(|t| {
                self.byzantine
                    .get(t.tx.sender as usize)
                    .copied()
                    .unwrap_or(false)
            })
            .count();
        if let Some(n) = self.summary.byzantine_majority_rounds.as_mut() {
            *n += u64::from(2 * byzantine > self.round_txs.len());
        }
        let loss = aggregated_loss(&mut self.summary, self.metrics, &self.round_txs);
        self.round_txs.clear();
        let s = &mut self.summary;
        s.rounds += 1;
        s.round_times_s
            .push(entry.block.header.timestamp_ms as f64 / 1000.0);
        s.loss_by_round.push(loss);
        s.heldout_loss_by_round
            .push(self.heldout.of(&entry.state.weights));
        s.mean_honest_distance_by_round
            .push(if self.round_honest > 0 {
                self.round_distance_sum / self.round_honest as f64
            } else {
                f64::NAN
            });
        (self.round_distance_sum, self.round_honest) = (0.0, 0);
        if self.ledger.params().outlier.is_some() {
            s.outlier_bound_by_round
                .push(entry.state.outlier_bound(self.ledger.params(), self.scale));
        }
    }

    /// The section after the last block: the means and final losses filled in.
    fn finish(self) -> ContractSummary {
        let mut s = self.summary;
        s.mean_honest_distance = (self.honest_accepted > 0)
            .then(|| self.honest_distance_sum / self.honest_accepted as f64);
        s.final_loss = s.loss_by_round.last().copied();
        s.final_heldout_loss = s.heldout_loss_by_round.last().copied();
        s.median_heldout_loss_last_1000s = median_last_window(
            &s.round_times_s,
            &s.heldout_loss_by_round,
            s.heldout_loss_initial,
            self.end_s,
        );
        if self.ledger.params().buffered.is_some() {
            let stale = s.submissions.get("stale").copied().unwrap_or(0);
            s.staleness = Some(Staleness::of(&self.ages, stale));
        }
        s
    }
}

/// The paper's loss of one aggregation of `models`: the sample-weighted mean validation loss
/// of its honest models (NaN if none has a finite one; Byzantine models have none). Counts each
/// model under `s.aggregated_honest` or `s.aggregated_byzantine`. The chain's rounds and the
/// baselines' aggregations (`aggregation/summary.rs`) share it.
pub(crate) fn aggregated_loss<'a>(
    s: &mut ContractSummary,
    metrics: &Metrics,
    models: impl IntoIterator<Item = &'a TxHash>,
) -> f64 {
    let (mut weighted, mut samples) = (0.0f64, 0.0f64);
    for tx in models {
        match metrics.trained.get(tx) {
            Some(record) if record.val_loss.is_finite() => {
                weighted += f64::from(record.train_samples) * record.val_loss;
                samples += f64::from(record.train_samples);
                s.aggregated_honest += 1;
            }
            Some(_) => s.aggregated_honest += 1,
            None => s.aggregated_byzantine += 1,
        }
    }
    if samples > 0.0 {
        weighted / samples
    } else {
        f64::NAN
    }
}

/// The tokens section: conservation, each group's mean gain and the balances at node `best`'s
/// head, and the control point found along its chain.
fn token_summary(
    config: &Config,
    ledger: &Ledger,
    best: RobotId,
    byzantine: &[bool],
    control: Option<ControlPoint>,
) -> TokenSummary {
    let head = ledger.head_state(best);
    let units = config.contract.token_units as f64;
    let initial = (config.contract.initial_tokens * config.contract.token_units) as f64;
    let gain = |want_byzantine: bool| -> Option<f64> {
        let gains: Vec<f64> = head
            .balances
            .iter()
            .zip(byzantine)
            .filter(|(_, &b)| b == want_byzantine)
            .map(|(&bal, _)| (bal as f64 - initial) / units)
            .collect();
        (!gains.is_empty()).then(|| gains.iter().sum::<f64>() / gains.len() as f64)
    };
    TokenSummary {
        total_units_start: ledger.params().total_units(),
        total_units_end: head.total_units(),
        honest_mean_gain: gain(false),
        byzantine_mean_gain: gain(true),
        balances: head.balances.iter().map(|&b| b as f64 / units).collect(),
        contract_holdings: head.holdings_units as f64 / units,
        byzantine_control: control,
    }
}

#[cfg(test)]
mod staleness_tests {
    use super::*;

    #[test]
    fn the_median_of_the_last_1000_s_samples_the_version_in_force() {
        // 5000 s run: versions at 100 s (loss 4), 4200 s (loss 2), 4600 s (loss 1). The
        // window 4000..=5000 s has 101 samples: 20 at 4 (4000..4190), 40 at 2, 41 at 1.
        let times = [100.0, 4200.0, 4600.0];
        let losses = [4.0, 2.0, 1.0];
        assert_eq!(median_last_window(&times, &losses, 9.0, 5000.0), Some(2.0));
        // A run shorter than the window starts at 0 with the initial loss in force.
        assert_eq!(median_last_window(&[], &[], 9.0, 300.0), Some(9.0));
        assert_eq!(median_last_window(&[], &[], f64::NAN, 300.0), None);
    }

    #[test]
    fn the_age_histogram_counts_each_update_at_its_age() {
        let s = Staleness::of(&[(0, 1000), (2, 30_000), (0, 5000)], 4);
        assert_eq!(s.age_versions, vec![2, 0, 1]);
        assert_eq!(
            (s.age_s.count, s.age_s.median_s, s.age_s.max_s),
            (3, 5.0, 30.0)
        );
        assert_eq!(s.stale_refusals, 4);
    }
}

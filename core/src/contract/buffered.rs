//! The buffered, staleness-aware protocol (`contract.protocol = "buffered"`, issue 32): FedBuff's
//! buffer of K updates with FedAsync's staleness weight, on chain, with the paper's stakes,
//! outlier check and reward rule.
//!
//! The paper's rounds judge every model against the newest shared model, so in a swarm wider
//! than one radio neighbourhood an honest robot whose chain lags is an outlier, and a quorum of
//! half the swarm is never reached. Here a submission names its *base*, the version it trained
//! from as its own chain showed it, and is judged against that base.
//!
//! # Rules, exactly
//!
//! `submitUpdate(w, n, base_round, base_digest)` sent by `sender` with `value` attached, at model
//! version `v` (the contract's `round`), is checked in this order; the first failing check
//! decides:
//! 1. `sender` is not an account, or the call is made under the paper's rounds (which take
//!    `submitModel`): [`Outcome::Malformed`]. (Under this protocol `submitModel` is malformed.)
//! 2. The model and claim checks of `submitModel` (samples, length, int48): malformed.
//! 3. The base: `base_round > v` is [`Refusal::FutureBase`]; `v - base_round >
//!    contract.max_staleness` is [`Refusal::Stale`]; a digest other than the one of version
//!    `base_round` on this chain is [`Refusal::UnknownBase`]; a base not newer than the base of
//!    the sender's last counted submission is [`Refusal::DuplicateBase`] (a robot counts once per
//!    base, and its bases only move forward). A refusal takes no stake (nothing leaves the
//!    sender), is the transaction's receipt ([`Outcome::Refused`], which `inspect` and the
//!    summary's submissions by outcome show) and is counted in the state
//!    ([`BufferState::refused`], in the state digest).
//! 4. The stake, exactly as `submitModel`'s.
//!
//! Then the distance `d = sum_i |w_i - b_i|` to the base `b` decides, with the paper's threshold
//! (`d <= threshold_units * N` accepted, else an outlier whose stake stays in the pool), or
//! under `contract.outlier_rule = "relative"` the bound that follows the accepted distances of
//! the last closed buffers ([`outlier`]); only the paper's rule checks it on arrival, as under
//! rounds. A counted submission (accepted or
//! outlier) records its base as the sender's last. An accepted one joins the buffer as the
//! update `u = w - b`, each weight clamped to int48.
//!
//! When the buffer holds K accepted updates (`contract.buffer_size`, the contract's quorum) the
//! submission that completes it is [`Outcome::Aggregated`]: with `tau_k = v - base_k` and the
//! staleness weight `s_k = S(tau_k)` (below), the rule in force (`contract.rule`, with its
//! pre-aggregators) aggregates the *updates* around the zero update (the shared model's place
//! in update space, so centered clipping, MoNNA, SignGuard and the clipping stage centre on the
//! model as under rounds). `fedavg` and `paper` weigh update k by `n_k * s_k`, so the
//! aggregate is the sample- and staleness-weighted mean `sum n_k s_k u_k / sum n_k s_k`
//! (FedAvg's exact `i128` quotient, rounded half away from zero); the robust rules ignore
//! weights, claimed samples and so staleness too (see `rules/`), and the staleness bound still
//! applies. The new model is `w_i + round(eta_units * U_i / STEP_SCALE)` (half away from zero),
//! clamped to int48. The used submissions are ranked and paid by the rule's reward rule
//! (the paper's ranking by `|d_k - median d|` on the distances to their bases, with the reward
//! weights of `contract.penalised_ranks` over K ranks), a defence scoring the updates rebased
//! on the shared model; the pool and carried remainder are the rounds' (`rewards.rs`).
//! Tokens are conserved exactly: integer stakes and payouts only.
//!
//! # Fixed point
//!
//! - Staleness weight: `S(tau) = max(1, round(STALENESS_SCALE * (1 + tau)^-a))`, with
//!   `STALENESS_SCALE = 2^16`, computed once per run for `tau = 0..=max_staleness` with
//!   `libm::pow` (portable) from `contract.staleness_exponent` and committed to by the genesis
//!   parameters; the contract only looks the table up. At least 1, so an accepted update always
//!   counts. With `n <= 2^32` the weight `n * S` stays below 2^48, and FedAvg's sums inside
//!   `i128`.
//! - Server step: `eta_units = round(contract.server_step * STEP_SCALE)`, `STEP_SCALE = 10^6`.
//!
//! # The staleness bound's default
//!
//! `contract.max_staleness = 64`: the newest version moves every K = 7 accepted submissions,
//! so at the paper's one submission per robot per 100 s a swarm of N robots makes about
//! `N / 700` versions a second, 14 per 10 s block at 1000 robots; 64 versions are about 4.5
//! blocks of gossip lag there, and a whole run's worth at 15 robots. Beyond it an update is
//! weighted below `65^-0.5 = 0.12` of a fresh one. Every node keeps the last 64 versions
//! ([`BufferState::history`]); they are the models its chain already stores, shared, not copies.
//!
//! # Deadline and restarts
//!
//! `contract.round_timeout_s` acts on the open buffer as on a round (accepted stakes refunded,
//! outliers' kept): the refunded senders' last bases are restored, so they may submit again
//! against the same base; so does a restart (`restart_round`), which refunds everyone.

use std::collections::VecDeque;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::payout::{self, div_round_half_away};
use super::{
    check_model, model_digest, outlier, preagg, rules, ContractParams, ContractState, Outcome,
    Payout, RoundSummary, Submission, Verdict, MAX_WEIGHT_MAGNITUDE,
};
use crate::config::{Config, RoundProtocol, Rule};
use crate::types::{Digest, RobotId};

/// Fixed-point scale of the staleness weight: `S(0) = 2^16`.
pub const STALENESS_SCALE: u64 = 1 << 16;

/// Fixed-point scale of the server step: `eta = 1` is `10^6`.
pub const STEP_SCALE: u64 = 1_000_000;

/// The largest weight magnitude a model may hold (int48).
const MAX_W: i128 = MAX_WEIGHT_MAGNITUDE as i128 - 1;

/// The buffered protocol's parameters, part of [`ContractParams`] (and of the genesis
/// commitment) only under `contract.protocol = "buffered"`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BufferedParams {
    /// The oldest base accepted, in versions behind the newest.
    pub max_staleness: u32,
    /// `S(tau)` for `tau = 0..=max_staleness`, scale [`STALENESS_SCALE`], each at least 1.
    pub staleness_weights: Vec<u64>,
    /// The server step, scale [`STEP_SCALE`].
    pub step_units: u64,
}

impl BufferedParams {
    /// The parameters of a run's configuration; `None` under the paper's rounds.
    pub fn from_config(config: &Config) -> Option<BufferedParams> {
        let c = &config.contract;
        if c.protocol != RoundProtocol::Buffered {
            return None;
        }
        Some(BufferedParams {
            max_staleness: c.max_staleness,
            staleness_weights: (0..=c.max_staleness)
                .map(|tau| staleness_weight(c.staleness_exponent, tau))
                .collect(),
            step_units: (c.server_step * STEP_SCALE as f64).round() as u64,
        })
    }

    /// Checks what the contract relies on (a table entry per staleness, positive weights and
    /// step); these come from a validated configuration, so a failure is a bug.
    pub fn check(&self) -> Result<(), String> {
        if self.staleness_weights.len() != self.max_staleness as usize + 1 {
            return Err("one staleness weight per staleness 0..=max_staleness".into());
        }
        if self
            .staleness_weights
            .iter()
            .any(|&s| s == 0 || s > STALENESS_SCALE)
        {
            return Err(format!(
                "staleness weights must be in 1..={STALENESS_SCALE}"
            ));
        }
        if self.step_units == 0 || self.step_units > 10 * STEP_SCALE {
            return Err("server step must be in (0, 10]".into());
        }
        Ok(())
    }

    /// `S(tau)`, or `None` beyond the bound.
    pub fn weight(&self, tau: u64) -> Option<u64> {
        usize::try_from(tau)
            .ok()
            .and_then(|t| self.staleness_weights.get(t).copied())
    }
}

/// `S(tau) = max(1, round(2^16 * (1 + tau)^-a))` (see the module doc).
pub fn staleness_weight(exponent: f64, tau: u32) -> u64 {
    let w = libm::pow(1.0 + f64::from(tau), -exponent) * STALENESS_SCALE as f64;
    (w.round() as u64).clamp(1, STALENESS_SCALE)
}

/// Why the contract refused a submission's base (no stake taken; see the module doc).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    /// The base's digest is not the one of that version on this chain.
    UnknownBase {
        /// The version named.
        base_round: u64,
    },
    /// The base is newer than the newest version on this chain.
    FutureBase {
        /// The version named.
        base_round: u64,
        /// The newest version.
        round: u64,
    },
    /// The base is more than `max_staleness` versions behind the newest.
    Stale {
        /// The version named.
        base_round: u64,
        /// The newest version.
        round: u64,
        /// `contract.max_staleness`.
        max_staleness: u32,
    },
    /// The sender already counted a submission against this base or a newer one.
    DuplicateBase {
        /// The version named.
        base_round: u64,
        /// The base of the sender's last counted submission.
        last_base: u64,
    },
}

impl Refusal {
    /// A short stable name, for metrics and receipts.
    pub fn name(&self) -> &'static str {
        match self {
            Refusal::UnknownBase { .. } => "unknown_base",
            Refusal::FutureBase { .. } => "future_base",
            Refusal::Stale { .. } => "stale",
            Refusal::DuplicateBase { .. } => "duplicate_base",
        }
    }

    /// The reason in words, with the fix.
    pub fn reason(&self) -> String {
        match self {
            Refusal::UnknownBase { base_round } => {
                format!("base version {base_round}'s digest is not this chain's; train from a version of this chain")
            }
            Refusal::FutureBase { base_round, round } => {
                format!("base version {base_round} is newer than this chain's newest, {round}")
            }
            Refusal::Stale {
                base_round,
                round,
                max_staleness,
            } => format!(
                "base version {base_round} is {} versions behind {round}, more than contract.max_staleness = {max_staleness}",
                round - base_round
            ),
            Refusal::DuplicateBase {
                base_round,
                last_base,
            } => format!(
                "already counted against base version {last_base}; base {base_round} is not newer"
            ),
        }
    }

    fn slot(&self) -> usize {
        match self {
            Refusal::UnknownBase { .. } => 0,
            Refusal::FutureBase { .. } => 1,
            Refusal::Stale { .. } => 2,
            Refusal::DuplicateBase { .. } => 3,
        }
    }
}

/// An open buffer's submission beyond what [`Submission`] holds (parallel to
/// [`ContractState::submissions`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BufferEntry {
    /// The version the submission trained from.
    pub base_round: u64,
    /// `w - base`, clamped to int48.
    pub update: Arc<[i64]>,
    /// The update rebased on the shared model, `w(v) + u` clamped to int48: what the
    /// Byzantine robots and a defence read as the submission's model in this buffer.
    pub rebased: Arc<[i64]>,
    /// The sender's last base before this submission (restored when its stake is refunded).
    pub previous_last_base: u64,
}

/// The buffered protocol's part of the contract state.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BufferState {
    /// The past versions `v - len ..= v - 1`, oldest first (digest, model): at most
    /// `max_staleness`.
    pub history: VecDeque<(Digest, Arc<[i64]>)>,
    /// The open buffer's entries, one per counted submission, in submission order.
    pub entries: Vec<BufferEntry>,
    /// Per robot: 1 + the base of its last counted submission (0: none).
    pub last_base: Vec<u64>,
    /// Refusals by reason: unknown base, future base, stale, duplicate base.
    pub refused: [u64; 4],
    /// The relative outlier rule's window of accepted distances ([`outlier`]); always empty
    /// under the absolute rule, and then in neither the encoding nor the digest.
    #[serde(default, skip_serializing_if = "outlier::Window::is_empty")]
    pub outlier_window: outlier::Window,
}

impl BufferState {
    /// The state at genesis for `robots` accounts.
    pub fn genesis(robots: u32) -> BufferState {
        BufferState {
            last_base: vec![0; robots as usize],
            ..BufferState::default()
        }
    }

    /// Refusals by reason, named as the outcomes.
    pub fn refusals(&self) -> [(&'static str, u64); 4] {
        let [u, f, s, d] = self.refused;
        [
            ("unknown_base", u),
            ("future_base", f),
            ("stale", s),
            ("duplicate_base", d),
        ]
    }

    /// Feeds the buffered part of the state digest.
    pub(super) fn hash(&self, h: &mut blake3::Hasher) {
        h.update(b"buffered v1");
        h.update(&(self.history.len() as u64).to_le_bytes());
        for (digest, _) in &self.history {
            h.update(&digest.0);
        }
        h.update(&(self.entries.len() as u64).to_le_bytes());
        for e in &self.entries {
            h.update(&e.base_round.to_le_bytes())
                .update(&e.previous_last_base.to_le_bytes());
        }
        for b in &self.last_base {
            h.update(&b.to_le_bytes());
        }
        for r in &self.refused {
            h.update(&r.to_le_bytes());
        }
        if !self.outlier_window.is_empty() {
            self.outlier_window.hash(h);
        }
    }

    /// Forgets the open buffer's entries of the refunded `senders` (a deadline or a restart
    /// refunded their stakes): their last bases go back to what they were before.
    pub(super) fn refund(
        &mut self,
        submissions: &[Submission],
        refunded: impl Fn(&Submission) -> bool,
    ) {
        let entries = std::mem::take(&mut self.entries);
        // Latest first, so that a robot with two entries ends at its base before both.
        for (s, e) in submissions.iter().zip(entries).rev() {
            if refunded(s) {
                if let Some(last) = self.last_base.get_mut(s.sender as usize) {
                    *last = e.previous_last_base;
                }
            }
        }
    }
}

/// `a + b` per weight, clamped to int48 (`b` may be negative).
fn add_clamped(a: &[i64], b: impl Iterator<Item = i128>) -> Arc<[i64]> {
    a.iter()
        .zip(b)
        .map(|(&x, d)| (i128::from(x) + d).clamp(-MAX_W, MAX_W) as i64)
        .collect()
}

impl ContractState {
    /// The model of the open round's `index`-th submission as the round reads it: its weights
    /// under rounds, its update rebased on the shared model under the buffered protocol.
    pub fn round_model(&self, index: usize) -> &Arc<[i64]> {
        match self.buffered.as_deref().and_then(|b| b.entries.get(index)) {
            Some(e) => &e.rebased,
            None => &self.submissions[index].weights,
        }
    }

    /// The version `base_round`'s digest and model on this chain, if it keeps it.
    fn version(&self, buffer: &BufferState, base_round: u64) -> Option<(Digest, Arc<[i64]>)> {
        let behind = self.round.checked_sub(base_round)?;
        if behind == 0 {
            return Some((self.weights_digest, self.weights.clone()));
        }
        let len = buffer.history.len() as u64;
        let i = len.checked_sub(behind)?;
        buffer
            .history
            .get(i as usize)
            .map(|(digest, weights)| (*digest, weights.clone()))
    }

    fn refuse(&mut self, refusal: Refusal) -> Outcome {
        if let Some(buffer) = self.buffered.as_mut() {
            Arc::make_mut(buffer).refused[refusal.slot()] += 1;
        }
        Outcome::Refused(refusal)
    }

    /// `submitUpdate`: see the module doc.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn submit_update(
        &mut self,
        params: &ContractParams,
        sender: RobotId,
        value_units: u64,
        weights: &Arc<[i64]>,
        samples: u64,
        base_round: u64,
        base_digest: &Digest,
    ) -> Outcome {
        let Some(&balance) = self.balances.get(sender as usize) else {
            return Outcome::Malformed(format!(
                "submission from {sender}: accounts are 0..{}",
                self.balances.len()
            ));
        };
        let (Some(bp), Some(buffer)) = (&params.buffered, self.buffered.clone()) else {
            return Outcome::Malformed(
                "submitUpdate needs contract.protocol = buffered; the paper's rounds take \
                 submitModel"
                    .to_string(),
            );
        };
        if let Err(reason) = check_model(params, weights, samples) {
            return Outcome::Malformed(reason);
        }
        let round = self.round;
        if base_round > round {
            return self.refuse(Refusal::FutureBase { base_round, round });
        }
        if round - base_round > u64::from(bp.max_staleness) {
            return self.refuse(Refusal::Stale {
                base_round,
                round,
                max_staleness: bp.max_staleness,
            });
        }
        let base = match self.version(&buffer, base_round) {
            Some((digest, base)) if digest == *base_digest => base,
            _ => return self.refuse(Refusal::UnknownBase { base_round }),
        };
        let previous_last_base = buffer.last_base[sender as usize];
        if previous_last_base > base_round {
            return self.refuse(Refusal::DuplicateBase {
                base_round,
                last_base: previous_last_base - 1,
            });
        }
        let stake_units = match super::submit::stake(params, value_units, balance) {
            Ok(units) => units,
            Err(refused) => return refused,
        };

        let distance_units = payout::distance_units(weights, &base);
        let max = self.outlier_bound_units(params);
        let verdict = super::submit::verdict(params, distance_units, max);
        let diff = weights
            .iter()
            .zip(base.iter())
            .map(|(&w, &b)| i128::from(w) - i128::from(b));
        let update = add_clamped(&vec![0; weights.len()], diff);
        let rebased = add_clamped(&self.weights, update.iter().map(|&u| i128::from(u)));

        self.take_stake_and_record(
            sender,
            samples,
            distance_units,
            stake_units,
            verdict,
            weights,
        );
        let b = Arc::make_mut(self.buffered.as_mut().expect("checked above"));
        b.entries.push(BufferEntry {
            base_round,
            update,
            rebased,
            previous_last_base,
        });
        b.last_base[sender as usize] = base_round + 1;
        self.conclude(params, round, distance_units, verdict, |state| {
            state.aggregate_buffer(params, bp)
        })
    }

    /// Closes the buffer: the rule on the weighted updates, the server step, the payouts,
    /// version += 1. Returns the payouts.
    fn aggregate_buffer(&mut self, params: &ContractParams, bp: &BufferedParams) -> Vec<Payout> {
        let submissions = std::mem::take(&mut self.submissions);
        let mut buffer = self.buffered.take().expect("a buffered state");
        let entries = std::mem::take(&mut Arc::make_mut(&mut buffer).entries);
        let accepted: Vec<(&Submission, &BufferEntry)> = submissions
            .iter()
            .zip(&entries)
            .filter(|(s, _)| s.verdict == Verdict::Accepted)
            .collect();
        assert_eq!(accepted.len(), params.quorum as usize);
        let weighted = matches!(params.rule(), Rule::Fedavg | Rule::Paper);
        let inputs: Vec<rules::Input> = accepted
            .iter()
            .map(|(s, e)| {
                let staleness = bp
                    .weight(self.round - e.base_round)
                    .expect("an accepted base is within the bound");
                rules::Input {
                    weights: &e.update,
                    samples: if weighted {
                        s.samples * staleness
                    } else {
                        s.samples
                    },
                    distance_units: s.distance_units,
                }
            })
            .collect();
        let seed = match params.preagg {
            Some(_) => {
                let ids: Vec<(RobotId, Digest)> = accepted
                    .iter()
                    .map(|(s, _)| (s.sender, s.weights_digest))
                    .collect();
                preagg::shuffle_seed(self.round, &self.weights_digest, &ids)
            }
            None => [0; 32],
        };
        let zero = vec![0i64; self.weights.len()];
        let aggregate = params.round_aggregate(&zero, &inputs, seed);
        assert_eq!(aggregate.weights.len(), self.weights.len());
        let step = i128::from(bp.step_units);
        let new_weights = add_clamped(
            &self.weights,
            aggregate
                .weights
                .iter()
                .map(|&u| div_round_half_away(i128::from(u) * step, i128::from(STEP_SCALE))),
        );

        let accepted_subs: Vec<&Submission> = accepted.iter().map(|(s, _)| *s).collect();
        let models: Vec<&[i64]> = accepted.iter().map(|(_, e)| &e.rebased[..]).collect();
        let (payouts, pool_units) = self.settle(
            params,
            &submissions,
            &accepted_subs,
            &models,
            &aggregate.used,
        );

        let b = Arc::make_mut(&mut buffer);
        if let Some(rule) = &params.outlier {
            let distances = accepted_subs.iter().map(|s| s.distance_units);
            b.outlier_window
                .record(distances, rule.window_len(params.quorum));
        }
        b.history
            .push_back((self.weights_digest, self.weights.clone()));
        while b.history.len() > bp.max_staleness as usize {
            b.history.pop_front();
        }
        self.buffered = Some(buffer);
        self.previous_weights = Some(std::mem::replace(&mut self.weights, new_weights));
        self.previous_digest = self.weights_digest;
        self.weights_digest = model_digest(&self.weights);
        self.last_round = Some(Arc::new(RoundSummary {
            round: self.round,
            submissions,
            payouts: payouts.clone(),
            pool_units,
            carried_units: self.holdings_units,
        }));
        self.round += 1;
        self.round_opened_ms = self.block_time_ms;
        payouts
    }
}

#[cfg(test)]
#[path = "buffered_tests.rs"]
mod tests;

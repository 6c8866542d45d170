//! The submit path that the paper's rounds (`submitModel`, `mod.rs`) and the buffered protocol
//! (`submitUpdate`, `buffered.rs`) share: the stake check, the outlier verdict, the stake moving
//! in with the submission's record, the outcome that closes or keeps the round open, and the
//! refund of an open round's stakes (a restart or a deadline). Each protocol keeps only what
//! differs: what a submission is judged against (the shared model or its base), its own
//! refusals, and how a full round aggregates.

use std::sync::Arc;

use super::{ContractParams, ContractState, Outcome, Payout, Submission, Verdict};
use crate::config::ThresholdRule;
use crate::types::RobotId;

/// The stake a submission moves in, or the outcome that refuses it (rule 4 of the module
/// documentation, under both protocols): with security on, exactly `params.stake_units`,
/// carried as the call's value and held by the sender; with security off, none (the value is
/// ignored).
pub(super) fn stake(
    params: &ContractParams,
    value_units: u64,
    balance_units: u64,
) -> Result<u64, Outcome> {
    if !params.security {
        return Ok(0);
    }
    if value_units < params.stake_units || balance_units < params.stake_units {
        return Err(Outcome::InsufficientStake);
    }
    if value_units > params.stake_units {
        return Err(Outcome::Malformed(format!(
            "value {value_units} exceeds the stake of {} units; send exactly the stake",
            params.stake_units
        )));
    }
    Ok(params.stake_units)
}

/// The verdict on a model at `distance_units` from the model it is judged against, with the
/// bound `max_units` in force: an outlier when the threshold applies on arrival
/// ([`ContractParams::threshold_applies`]) and the distance is beyond the bound (inclusive or
/// strict, `contract.threshold`), accepted otherwise.
pub(super) fn verdict(params: &ContractParams, distance_units: u64, max_units: u128) -> Verdict {
    let distance = u128::from(distance_units);
    let beyond = match params.options.threshold {
        ThresholdRule::Inclusive => distance > max_units,
        ThresholdRule::Strict => distance >= max_units,
    };
    if params.threshold_applies() && beyond {
        Verdict::Outlier
    } else {
        Verdict::Accepted
    }
}

impl ContractState {
    /// Takes `stake_units` from `sender`'s balance (checked by [`stake`] to hold it) into the
    /// contract's holdings and records the submission: the one place a stake moves in, under
    /// every protocol, so that conservation has one code path to hold on.
    pub(super) fn take_stake_and_record(
        &mut self,
        sender: RobotId,
        samples: u64,
        distance_units: u64,
        stake_units: u64,
        verdict: Verdict,
        weights: &Arc<[i64]>,
    ) {
        self.balances[sender as usize] -= stake_units;
        self.holdings_units = self
            .holdings_units
            .checked_add(stake_units)
            .expect("supply fits u64");
        self.submissions.push(Submission {
            sender,
            samples,
            distance_units,
            stake_units,
            verdict,
            weights: weights.clone(),
            weights_digest: super::model_digest(weights),
        });
    }

    /// The outcome of a recorded submission of round `round`: an outlier, an accepted model
    /// that leaves the round open, or the one that completes the quorum, whereupon `close`
    /// aggregates the round (the protocol's own) and returns its payouts.
    pub(super) fn conclude(
        &mut self,
        params: &ContractParams,
        round: u64,
        distance_units: u64,
        verdict: Verdict,
        close: impl FnOnce(&mut ContractState) -> Vec<Payout>,
    ) -> Outcome {
        if verdict == Verdict::Outlier {
            return Outcome::Outlier {
                round,
                distance_units,
            };
        }
        let accepted = self.accepted_count();
        assert!(
            accepted <= params.quorum,
            "a round (or buffer) never exceeds the quorum (or K)"
        );
        if accepted < params.quorum {
            return Outcome::Accepted {
                round,
                distance_units,
            };
        }
        let payouts = close(self);
        Outcome::Aggregated {
            round,
            distance_units,
            payouts,
        }
    }

    /// Ends the open round's submissions: those `refunded` selects get their stake back from
    /// the contract (and, under the buffered protocol, their sender its last base), the others'
    /// stakes stay in the pool. Returns the units refunded.
    pub(super) fn refund_open_round(&mut self, refunded: impl Fn(&Submission) -> bool) -> u64 {
        if let Some(b) = self.buffered.as_mut() {
            Arc::make_mut(b).refund(&self.submissions, &refunded);
        }
        let mut refunded_units = 0;
        for s in std::mem::take(&mut self.submissions) {
            if !refunded(&s) {
                continue;
            }
            self.holdings_units = self
                .holdings_units
                .checked_sub(s.stake_units)
                .expect("the contract holds the open round's stakes");
            let balance = &mut self.balances[s.sender as usize];
            *balance = balance
                .checked_add(s.stake_units)
                .expect("conserved supply fits u64");
            refunded_units += s.stake_units;
        }
        refunded_units
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{params, STAKE};
    use super::*;

    /// The stake rule both protocols apply: `(security, value, balance) -> stake or outcome`.
    #[test]
    fn the_stake_is_exact_and_held() {
        let on = params(3, vec![1, 1], 2);
        let off = ContractParams {
            security: false,
            ..params(3, vec![1, 1], 2)
        };
        let check = |p: &ContractParams, value: u64, balance: u64, expect: Result<u64, &str>| {
            let got = stake(p, value, balance).map_err(|o| o.name());
            assert_eq!(got, expect, "value {value}, balance {balance}");
        };
        check(&on, STAKE, STAKE, Ok(STAKE));
        check(&on, STAKE - 1, 10 * STAKE, Err("insufficient_stake"));
        check(&on, STAKE, STAKE - 1, Err("insufficient_stake"));
        check(&on, STAKE + 1, 10 * STAKE, Err("malformed"));
        check(&off, 0, 0, Ok(0));
        check(&off, STAKE + 1, 0, Ok(0));
    }

    /// The verdict at the bound: inclusive accepts a distance equal to it, strict refuses it;
    /// a rule that does not apply the threshold on arrival accepts everything.
    #[test]
    fn the_verdict_follows_the_bound_and_the_threshold_rule() {
        let inclusive = params(3, vec![1, 1], 2);
        let mut strict = params(3, vec![1, 1], 2);
        strict.options.threshold = ThresholdRule::Strict;
        let fedavg_like = ContractParams {
            security: false,
            ..params(3, vec![1, 1], 2)
        };
        for (p, distance, expect) in [
            (&inclusive, 100, Verdict::Accepted),
            (&inclusive, 101, Verdict::Outlier),
            (&strict, 99, Verdict::Accepted),
            (&strict, 100, Verdict::Outlier),
            (&fedavg_like, u64::MAX, Verdict::Accepted),
        ] {
            assert_eq!(verdict(p, distance, 100), expect, "distance {distance}");
        }
    }
}

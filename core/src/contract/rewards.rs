//! Settling an aggregation: the pool, the payouts of the used submissions (the paper's
//! ranking and reward weights, a defence's scores, or equal shares) and the credits, shared by
//! the paper's rounds (`mod.rs`) and the buffered protocol (`buffered.rs`), so that both pay by
//! one rule, in integers, and conserve tokens exactly.

use super::{defences, payout, ContractParams, ContractState, Payout, Submission};
use crate::config::{PoolRule, Rule};

impl ContractState {
    /// Pays the pool of an aggregation and credits the payouts; returns them (in the rule's
    /// used order) and the pool. `submissions` are the aggregation's counted submissions
    /// (accepted and outliers), `accepted` its accepted ones in chain order, `models[i]` the
    /// model a defence scores for `accepted[i]` (its weights, or under the buffered protocol
    /// its update rebased on the shared model), `used` the rule's used indices into
    /// `accepted`, best first.
    pub(super) fn settle(
        &mut self,
        params: &ContractParams,
        submissions: &[Submission],
        accepted: &[&Submission],
        models: &[&[i64]],
        used: &[usize],
    ) -> (Vec<Payout>, u64) {
        let rule = params.rule();
        let stakes: u128 = submissions.iter().map(|s| u128::from(s.stake_units)).sum();
        let pool_units = match params.options.pool {
            PoolRule::Carry => self.holdings_units,
            PoolRule::Round if params.security => u64::try_from(stakes).expect("stakes are held"),
            PoolRule::Round => self.holdings_units,
        };
        let mut payouts = Vec::new();
        if params.security {
            assert!(
                u128::from(pool_units) >= stakes,
                "the pool holds the round's stakes"
            );
            assert!(
                u128::from(pool_units)
                    >= u128::from(params.quorum) * u128::from(params.stake_units),
                "every accepted submission staked"
            );
            let order = used;
            if let Some(defence) = params.defence {
                // The defence replaces the reward rule: score the used models, share the pool.
                let models: Vec<&[i64]> = order.iter().map(|&i| models[i]).collect();
                let scores = defences::scores(
                    defence.defence,
                    &self.weights,
                    self.previous_weights.as_deref(),
                    &models,
                );
                let units = defences::payouts(pool_units, &scores, defence.refund_percent);
                for (rank, ((&i, units), score)) in order.iter().zip(units).zip(scores).enumerate()
                {
                    payouts.push(Payout {
                        robot: accepted[i].sender,
                        rank: rank as u32,
                        reward_weight: score,
                        units,
                    });
                }
            } else if rule == Rule::Paper {
                let ranked_samples: Vec<u64> = order.iter().map(|&i| accepted[i].samples).collect();
                let units = payout::payouts(
                    pool_units,
                    params.stake_units,
                    &ranked_samples,
                    &params.reward_weights,
                    params.options.payout_rounding,
                );
                // Rounded-down penalties (ratio_1e9) can ask for a few units more than the
                // pool: they come from what the contract holds, and run out in rank order.
                let mut available = self.holdings_units;
                for (rank, (&i, units)) in order.iter().zip(units).enumerate() {
                    let units = units.min(available);
                    available -= units;
                    payouts.push(Payout {
                        robot: accepted[i].sender,
                        rank: rank as u32,
                        reward_weight: params.reward_weights[rank],
                        units,
                    });
                }
            } else {
                let units = payout::equal_shares(pool_units, order.len());
                for (rank, &i) in order.iter().enumerate() {
                    payouts.push(Payout {
                        robot: accepted[i].sender,
                        rank: rank as u32,
                        reward_weight: 1,
                        units,
                    });
                }
            }
        }
        let paid: u64 = payouts.iter().map(|p| p.units).sum();
        assert!(
            paid <= self.holdings_units,
            "payouts {paid} exceed the holdings {}",
            self.holdings_units
        );
        for p in &payouts {
            let balance = &mut self.balances[p.robot as usize];
            *balance = balance
                .checked_add(p.units)
                .expect("conserved supply fits u64");
        }
        self.holdings_units -= paid;
        (payouts, pool_units)
    }
}

//! Where each submission of each closed round sat in its round's ranking (issue #36): its
//! distance to the shared model, the median distance of the round's accepted models, its
//! distance to that median (the paper's ranking key), the rank the contract gave it and what
//! it was paid. Everything comes from the contract's own record of the round
//! ([`RoundSummary`]: the counted submissions with their distances, the payouts in rank
//! order), so the table shows the contract's decisions, never a recomputation of them.

use super::error::InspectError;
use super::index::RunIndex;
use super::tables::{Column, Table};
use crate::config::{Aggregation, MedianRule};
use crate::contract::{payout, RoundSummary, Verdict};

/// One counted submission of a closed round, placed in that round's ranking. Distances are in
/// the contract's fixed-point units of `sum_i |w_i - w(t)_i|`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RankedSubmission {
    /// The round, numbered from 1 (as everywhere the user sees rounds).
    pub round: u64,
    /// Height of the block that closed it.
    pub block: u64,
    /// The sender.
    pub robot: u32,
    /// Whether the sender is Byzantine.
    pub byzantine: bool,
    /// Accepted (ranked) or an outlier (never ranked).
    pub accepted: bool,
    /// Its distance to the shared model it was checked against.
    pub distance_units: u64,
    /// The median distance of the round's accepted submissions (the contract's
    /// `contract.median` rule for an even count).
    pub median_units: u64,
    /// `|distance - median|`: the paper's ranking key on the exact distance.
    pub off_median_units: u64,
    /// Its rank, 1 = paid best; `None` when not ranked (an outlier).
    pub rank: Option<u32>,
    /// How many submissions the round ranked.
    pub ranked: u32,
    /// The reward weight of its rank (negative: a penalised rank; under a defence, its score);
    /// `None` when not ranked.
    pub reward_weight: Option<i64>,
    /// Units it staked.
    pub stake_units: u64,
    /// Units the aggregation paid back to it (0 when not paid).
    pub paid_units: u64,
}

/// The submissions of one closed round in submission order, placed in its ranking. The median
/// is taken over the accepted submissions' distances by `median_rule` (the round's ranking
/// centre under `contract.rank_order = "median"`); a round without accepted submissions has
/// median 0. `round` and `block` are the user's round number and the closing block.
pub fn rank_round(
    summary: &RoundSummary,
    round: u64,
    block: u64,
    median_rule: MedianRule,
    byzantine: &[bool],
) -> Vec<RankedSubmission> {
    let accepted: Vec<u64> = summary
        .submissions
        .iter()
        .filter(|s| s.verdict == Verdict::Accepted)
        .map(|s| s.distance_units)
        .collect();
    let median = if accepted.is_empty() {
        0
    } else {
        payout::median(&accepted, median_rule)
    };
    summary
        .submissions
        .iter()
        .map(|s| {
            let paid = summary.payouts.iter().find(|p| p.robot == s.sender);
            RankedSubmission {
                round,
                block,
                robot: s.sender,
                byzantine: byzantine.get(s.sender as usize).copied().unwrap_or(false),
                accepted: s.verdict == Verdict::Accepted,
                distance_units: s.distance_units,
                median_units: median,
                off_median_units: s.distance_units.abs_diff(median),
                rank: paid.map(|p| p.rank + 1),
                ranked: summary.payouts.len() as u32,
                reward_weight: paid.map(|p| p.reward_weight),
                stake_units: s.stake_units,
                paid_units: paid.map_or(0, |p| p.units),
            }
        })
        .collect()
}

impl RunIndex {
    /// Every counted submission of every closed round of the final canonical chain, in round
    /// and then submission order, placed in its round's ranking ([`rank_round`]).
    pub fn ranked_submissions(&self) -> Result<Vec<RankedSubmission>, InspectError> {
        let kind = self.config.learn.aggregation;
        if kind != Aggregation::Chain {
            return Err(InspectError::Inconsistent {
                path: self.path.clone(),
                message: format!(
                    "a {} run has no ranking: it has no contract (learn.aggregation = \"{}\")",
                    kind.name(),
                    kind.name()
                ),
            });
        }
        let median_rule = self.final_state.ledger.params().options.median;
        let mut out = Vec::new();
        for (height, summary) in self.closed_rounds() {
            out.extend(rank_round(
                summary,
                summary.round + 1,
                height,
                median_rule,
                &self.byzantine,
            ));
        }
        Ok(out)
    }

    /// [`RunIndex::ranked_submissions`] as a table: `round`, `block`, `robot`, `byzantine`,
    /// `outcome` (`accepted` or `outlier`), `distance`, `median_distance`, `off_median` (mean
    /// absolute distance per weight, in model units: to the shared model, the round's median
    /// of it, and `|distance - median_distance|`), `rank` (1 = paid best; 0 = not ranked),
    /// `ranked`, `reward_weight` (0 when not ranked), `stake_tokens`, `reward_tokens`,
    /// `gain_tokens` (reward minus stake).
    pub fn ranking_table(&self) -> Result<Table, InspectError> {
        let rows = self.ranked_submissions()?;
        let params = self.final_state.ledger.params();
        let scale = self.config.contract.weight_scale;
        let per_weight = |units: u64| params.distance_per_weight(units, scale);
        let mut t = Table::default();
        let col = |f: &dyn Fn(&RankedSubmission) -> u64| rows.iter().map(f).collect::<Vec<_>>();
        t.push("round", Column::U64(col(&|r| r.round)));
        t.push("block", Column::U64(col(&|r| r.block)));
        t.push("robot", Column::U64(col(&|r| u64::from(r.robot))));
        t.push(
            "byzantine",
            Column::Bool(rows.iter().map(|r| r.byzantine).collect()),
        );
        t.push(
            "outcome",
            Column::Str(
                rows.iter()
                    .map(|r| if r.accepted { "accepted" } else { "outlier" }.to_string())
                    .collect(),
            ),
        );
        let dist = |f: &dyn Fn(&RankedSubmission) -> u64| {
            Column::F64(rows.iter().map(|r| per_weight(f(r))).collect())
        };
        t.push("distance", dist(&|r| r.distance_units));
        t.push("median_distance", dist(&|r| r.median_units));
        t.push("off_median", dist(&|r| r.off_median_units));
        t.push(
            "rank",
            Column::U64(col(&|r| u64::from(r.rank.unwrap_or(0)))),
        );
        t.push("ranked", Column::U64(col(&|r| u64::from(r.ranked))));
        t.push(
            "reward_weight",
            Column::I64(rows.iter().map(|r| r.reward_weight.unwrap_or(0)).collect()),
        );
        t.push(
            "stake_tokens",
            Column::F64(rows.iter().map(|r| self.tokens(r.stake_units)).collect()),
        );
        t.push(
            "reward_tokens",
            Column::F64(rows.iter().map(|r| self.tokens(r.paid_units)).collect()),
        );
        t.push(
            "gain_tokens",
            Column::F64(
                rows.iter()
                    .map(|r| self.tokens(r.paid_units) - self.tokens(r.stake_units))
                    .collect(),
            ),
        );
        Ok(t)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::contract::{Payout, Submission};
    use crate::types::Digest;

    fn submission(sender: u32, distance_units: u64, verdict: Verdict) -> Submission {
        Submission {
            sender,
            samples: 10,
            distance_units,
            stake_units: 5,
            verdict,
            weights: Arc::from(Vec::new()),
            weights_digest: Digest([0; 32]),
        }
    }

    fn payout(robot: u32, rank: u32, reward_weight: i64, units: u64) -> Payout {
        Payout {
            robot,
            rank,
            reward_weight,
            units,
        }
    }

    #[test]
    fn a_round_is_placed_around_the_median_of_its_accepted_distances() {
        // Robot 3 (Byzantine) sits below the honest cluster 100, 110, 120; robot 4 is an
        // outlier and does not move the median. Accepted distances 100, 110, 40, 120: the
        // lower middle of 40, 100, 110, 120 is 100 (the floored mean of the middles, 105).
        let summary = RoundSummary {
            round: 6,
            submissions: vec![
                submission(0, 100, Verdict::Accepted),
                submission(1, 110, Verdict::Accepted),
                submission(3, 40, Verdict::Accepted),
                submission(4, 9000, Verdict::Outlier),
                submission(2, 120, Verdict::Accepted),
            ],
            // Ranked around 100: keys 0, 10, 60, 20 -> robots 0, 1, 2, 3.
            payouts: vec![
                payout(0, 0, 1, 8),
                payout(1, 1, 1, 7),
                payout(2, 2, -1, 3),
                payout(3, 3, -1, 2),
            ],
            pool_units: 25,
            carried_units: 5,
        };
        let byzantine = [false, false, false, true, false];
        let rows = rank_round(&summary, 7, 30, MedianRule::Lower, &byzantine);
        assert_eq!(rows.len(), 5);
        let got: Vec<_> = rows
            .iter()
            .map(|r| {
                (
                    r.robot,
                    r.median_units,
                    r.off_median_units,
                    r.rank,
                    r.paid_units,
                )
            })
            .collect();
        assert_eq!(
            got,
            [
                (0, 100, 0, Some(1), 8),
                (1, 100, 10, Some(2), 7),
                (3, 100, 60, Some(4), 2),
                (4, 100, 8900, None, 0),
                (2, 100, 20, Some(3), 3),
            ]
        );
        assert!(rows[2].byzantine && !rows[0].byzantine);
        assert_eq!(rows[2].reward_weight, Some(-1));
        assert_eq!(rows[3].reward_weight, None);
        assert!(!rows[3].accepted);
        assert!(rows
            .iter()
            .all(|r| r.round == 7 && r.block == 30 && r.ranked == 4));
        let mean = rank_round(&summary, 7, 30, MedianRule::Mean, &byzantine);
        assert_eq!(mean[0].median_units, 105);
        assert_eq!(mean[2].off_median_units, 65);
    }
}

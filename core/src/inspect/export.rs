//! The closed rounds of the final canonical chain, the table `swarmfl export` writes (its other
//! tables read the index's rows directly).

use serde::Serialize;

use super::index::RunIndex;
use crate::contract::{Outcome, RoundSummary, Verdict};
use crate::ledger::TxHash;

/// One closed round of the final canonical chain.
#[derive(Clone, Debug, Serialize)]
pub struct RoundRow {
    /// The round that closed, numbered from 1 in closing order as everywhere in swarmfl (the
    /// run summary's `r1` is round 1); after it the shared model has version `round`.
    pub round: u64,
    /// Height of the block that closed it.
    pub block: u64,
    /// Its timestamp, s.
    pub time_s: f64,
    /// The paper metric: mean validation loss of the honest aggregated models, weighted by
    /// their training samples (NaN when no honest model was aggregated).
    pub loss: f64,
    /// Accepted submissions of the round (the quorum).
    pub accepted: u64,
    /// Outlier submissions of the round.
    pub outliers: u64,
    /// Mean absolute distance per weight between the round's accepted honest models and the
    /// shared model they were checked against (NaN without one): how close honest robots come
    /// to the outlier threshold.
    pub mean_honest_distance: f64,
}

impl RunIndex {
    /// The rounds closed on the final canonical chain, in order.
    pub fn rounds(&self) -> Vec<RoundRow> {
        let ledger = &self.final_state.ledger;
        let mut out = Vec::new();
        let mut round_txs = Vec::new();
        for row in &self.chain {
            let entry = ledger
                .block(&row.hash)
                .expect("canonical blocks are stored");
            for (tx_hash, outcome) in entry.block.txs.iter().zip(entry.receipts.iter()) {
                if outcome.is_accepted() {
                    round_txs.push(*tx_hash);
                }
                if let Outcome::Aggregated { round, .. } = outcome {
                    let summary = entry.state.last_round.as_deref();
                    let count = |v: Verdict| {
                        summary.map_or(0, |s| {
                            s.submissions.iter().filter(|x| x.verdict == v).count() as u64
                        })
                    };
                    out.push(RoundRow {
                        mean_honest_distance: self.mean_honest_distance(summary),
                        // The contract counts model versions from 0: the round that closes
                        // version v into v + 1 is round v + 1.
                        round: *round + 1,
                        block: row.height,
                        time_s: row.time.secs(),
                        loss: self.paper_loss(&round_txs),
                        accepted: count(Verdict::Accepted),
                        outliers: count(Verdict::Outlier),
                    });
                    round_txs.clear();
                }
            }
        }
        out
    }

    /// The paper metric of a round from its accepted transactions: their models' validation
    /// losses weighted by training samples (NaN when none is known and finite).
    fn paper_loss(&self, round_txs: &[TxHash]) -> f64 {
        let trained = &self.final_state.metrics.trained;
        let (mut weighted, mut samples) = (0.0f64, 0.0f64);
        for tx in round_txs {
            if let Some(r) = trained.get(tx) {
                if r.val_loss.is_finite() {
                    weighted += f64::from(r.train_samples) * r.val_loss;
                    samples += f64::from(r.train_samples);
                }
            }
        }
        if samples > 0.0 {
            weighted / samples
        } else {
            f64::NAN
        }
    }

    /// [`RoundRow::mean_honest_distance`] of a closed round.
    fn mean_honest_distance(&self, summary: Option<&RoundSummary>) -> f64 {
        let params = self.final_state.ledger.params();
        let scale = self.config.contract.weight_scale;
        let honest: Vec<f64> = summary
            .map(|s| {
                s.submissions
                    .iter()
                    .filter(|x| {
                        x.verdict == Verdict::Accepted
                            && !self
                                .byzantine
                                .get(x.sender as usize)
                                .copied()
                                .unwrap_or(false)
                    })
                    .map(|x| params.distance_per_weight(x.distance_units, scale))
                    .collect()
            })
            .unwrap_or_default();
        if honest.is_empty() {
            f64::NAN
        } else {
            honest.iter().sum::<f64>() / honest.len() as f64
        }
    }
}

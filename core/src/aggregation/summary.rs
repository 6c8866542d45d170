//! The figures of a run for every aggregation, in one shape: the contract section's loss per
//! aggregation and held-out loss (computed from the aggregation records of a baseline as from
//! the final canonical chain of the chain), and the bytes each robot sends and stores.

use std::collections::BTreeMap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{AggregationRecord, AggregationState};
use crate::config::{Aggregation, Config};
use crate::data::Sample;
use crate::ledger::LedgerStats;
use crate::metrics::{aggregated_loss, ContractSummary, HeldoutLoss, Metrics};

/// The `aggregation` section of `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AggregationSummary {
    /// `chain`, `gossip` or `central`.
    pub kind: Aggregation,
    /// Token conservation: `"holds"` (checked after every contract call) or why it does not
    /// apply.
    pub conservation: String,
    /// Mean over robots of the bytes each put on the radio for aggregation (chain: gossip of
    /// blocks and transactions; gossip: stigmergy messages; central: uploads), lost ones
    /// included.
    pub bytes_sent_per_robot_mean: f64,
    /// Mean over robots of the bytes each stores for aggregation at the end (chain: every block
    /// it holds; gossip: its replica; central: its own model).
    pub bytes_stored_per_robot_mean: f64,
    /// `central`: mean bytes each robot downloads from the server (0 otherwise).
    pub bytes_downloaded_per_robot_mean: f64,
    /// Messages sent and lost (chain: ledger gossip; gossip: stigmergy; central: 0).
    pub messages_sent: u64,
    /// Messages lost.
    pub messages_lost: u64,
    /// Per honest robot (robot order), the held-out loss of the model it would start from at
    /// the end (chain: the final canonical head's shared model for all).
    #[serde(deserialize_with = "crate::metrics::nans_from_nulls")]
    pub final_heldout_loss_per_robot: Vec<f64>,
}

impl Default for AggregationSummary {
    fn default() -> Self {
        AggregationSummary {
            kind: Aggregation::Chain,
            conservation: "holds".to_string(),
            bytes_sent_per_robot_mean: 0.0,
            bytes_stored_per_robot_mean: 0.0,
            bytes_downloaded_per_robot_mean: 0.0,
            messages_sent: 0,
            messages_lost: 0,
            final_heldout_loss_per_robot: Vec::new(),
        }
    }
}

/// The mean over robots of one count per robot (robot order, summed as floats in that order):
/// the summary's bytes per robot, and `swarmfl traffic`'s at every moment.
pub(crate) fn per_robot_mean(v: &[u64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
    }
}

/// The aggregation section of a chain run.
pub fn chain_summary(
    config: &Config,
    stats: &LedgerStats,
    final_heldout: f64,
) -> AggregationSummary {
    let robots = f64::from(config.world.robots.max(1));
    AggregationSummary {
        kind: Aggregation::Chain,
        conservation:
            "holds: sum(balances) + contract holdings is asserted after every contract call"
                .to_string(),
        bytes_sent_per_robot_mean: stats.gossip_bytes as f64 / robots,
        bytes_stored_per_robot_mean: stats.stored_bytes_mean,
        bytes_downloaded_per_robot_mean: 0.0,
        messages_sent: stats.messages_sent,
        messages_lost: stats.messages_lost,
        final_heldout_loss_per_robot: vec![final_heldout; config.world.robots as usize],
    }
}

/// The contract-shaped section and the aggregation section of a baseline run. Loss per
/// aggregation: the sample-weighted mean validation loss of the honest models averaged (as the
/// paper's loss per round); held-out loss: of the aggregated model. `gossip` counts the merges
/// of honest robots only (a Byzantine robot's own model is not what the swarm learns), and its
/// final held-out loss is the mean over honest robots of their current models' held-out losses.
pub fn summarise(
    config: &Config,
    state: &AggregationState,
    metrics: &Metrics,
    heldout: &[Sample],
    byzantine: &[bool],
) -> (ContractSummary, AggregationSummary) {
    let heldout = HeldoutLoss::new(config, heldout);
    let is_byzantine = |r: u32| byzantine.get(r as usize).copied().unwrap_or(false);
    let records: Vec<&AggregationRecord> = state
        .aggregations
        .iter()
        .filter(|a| a.robot.is_none_or(|r| !is_byzantine(r)))
        .collect();
    // Held-out evaluations are independent: computed in parallel, collected in order.
    let heldout_losses: Vec<f64> = records.par_iter().map(|a| heldout.of(&a.weights)).collect();
    let honest: Vec<u32> = (0..config.world.robots)
        .filter(|&r| !is_byzantine(r))
        .collect();
    let models = state.models();
    let per_robot: Vec<f64> = honest
        .par_iter()
        .map(|&r| heldout.of(&models[r as usize]))
        .collect();
    let mut s = ContractSummary {
        rounds: records.len() as u64,
        round_times_s: records.iter().map(|a| a.time.secs()).collect(),
        loss_by_round: Vec::with_capacity(records.len()),
        heldout_loss_by_round: heldout_losses,
        heldout_loss_initial: heldout.of(state.genesis()),
        final_loss: None,
        final_heldout_loss: None,
        // No contract measures distances to a shared model.
        mean_honest_distance: None,
        outlier_threshold: config.contract.outlier_threshold,
        mean_honest_distance_by_round: Vec::new(),
        outlier_bound_by_round: Vec::new(),
        honest_outliers: None,
        max_claimed_samples: None,
        rounds_timed_out: 0,
        submissions: BTreeMap::new(),
        aggregated_honest: 0,
        aggregated_byzantine: 0,
        // Rounds of accepted submissions are the chain's.
        byzantine_majority_rounds: None,
        skipped: metrics
            .skipped
            .iter()
            .map(|(k, v)| (k.name().to_string(), *v))
            .collect(),
        median_heldout_loss_last_1000s: None,
        staleness: None,
    };
    for a in &records {
        let loss = aggregated_loss(&mut s, metrics, &a.models);
        s.loss_by_round.push(loss);
    }
    count_submissions(&mut s, state, metrics);
    s.final_loss = s.loss_by_round.last().copied();
    s.median_heldout_loss_last_1000s = crate::metrics::median_last_window(
        &s.round_times_s,
        &s.heldout_loss_by_round,
        s.heldout_loss_initial,
        config.run.duration_s,
    );
    if state.kind() == Aggregation::Matched {
        s.staleness = Some(crate::metrics::Staleness::of(&state.matched.ages, 0));
    }
    s.final_heldout_loss = match state.kind() {
        Aggregation::Central | Aggregation::Matched => s.heldout_loss_by_round.last().copied(),
        _ => {
            (!per_robot.is_empty()).then(|| per_robot.iter().sum::<f64>() / per_robot.len() as f64)
        }
    };
    (s, baseline_summary(state, per_robot))
}

/// A baseline's submissions: every model written (trained or forged) is `accepted` but for
/// the central server's `duplicate`s.
fn count_submissions(s: &mut ContractSummary, state: &AggregationState, metrics: &Metrics) {
    let written = metrics.trained.len() as u64 + metrics.forged;
    let duplicates = state.server.duplicates;
    s.submissions
        .insert("accepted".to_string(), written.saturating_sub(duplicates));
    if duplicates > 0 {
        s.submissions.insert("duplicate".to_string(), duplicates);
    }
}

/// The aggregation section of a baseline run, with each honest robot's final held-out loss
/// (`per_robot`).
fn baseline_summary(state: &AggregationState, per_robot: Vec<f64>) -> AggregationSummary {
    let kind = state.kind();
    AggregationSummary {
        kind,
        conservation: format!(
            "not applicable: the {} aggregation has no tokens",
            kind.name()
        ),
        bytes_sent_per_robot_mean: per_robot_mean(&state.bytes_sent),
        bytes_stored_per_robot_mean: per_robot_mean(&state.stored_bytes()),
        bytes_downloaded_per_robot_mean: per_robot_mean(&state.bytes_downloaded),
        messages_sent: state.stigmergy.messages_sent(),
        messages_lost: state.stigmergy.messages_lost,
        final_heldout_loss_per_robot: per_robot,
    }
}

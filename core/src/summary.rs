//! The figures of a finished run for `summary.json`, read off the reduced [`State`].

use crate::aggregation::{self, AggregationSummary};
use crate::byzantine;
use crate::config::{Aggregation, ByzantineKind, Config, LedgerBehaviour};
use crate::ledger::geth::{self, GethEquivalent};
use crate::ledger::{Ledger, LedgerStats};
use crate::metrics::{self, ContractSummary, TokenSummary};
use crate::state::State;
use crate::types::{Digest, RobotId, SimTime};
use crate::world::WorldStats;

/// The ledger section of `summary.json`: the headline figures, then every detail.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct LedgerSummary {
    /// Highest canonical head over nodes.
    pub canonical_height: u64,
    /// Branchings of the block tree.
    pub forks: u64,
    /// Reorganisations over all nodes.
    pub reorgs: u64,
    /// Most blocks removed by one reorganisation.
    pub deepest_reorg: u64,
    /// Median delay from submission until every node knows the transaction, simulated s.
    pub tx_delay_median_s: f64,
    /// 95th percentile of the same.
    pub tx_delay_p95_s: f64,
    /// Mean encoded size of a model submission, bytes.
    pub bytes_per_submission: f64,
    /// Canonical chain size per node over time (every 100 s).
    pub chain_bytes: Vec<ChainBytesPoint>,
    /// Everything the ledger measured.
    pub details: LedgerStats,
    /// With `contract.engine = "evm"` only: the bytes a geth node would hold for the same
    /// chain (`ledger/geth.rs`; docs/CONTRACT.md, "What a geth node would store"). Absent
    /// otherwise, so native summaries are unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geth_equivalent: Option<GethEquivalent>,
}

/// One point of the chain-size series.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ChainBytesPoint {
    /// Simulated time, s.
    pub time_s: f64,
    /// Mean over nodes, bytes.
    pub mean: f64,
    /// Largest node, bytes.
    pub max: f64,
    /// Blocks held per node (side branches included), mean over nodes, bytes.
    #[serde(default)]
    pub stored_mean: f64,
    /// Gossip bytes sent so far per node, mean over nodes (lost ones included).
    #[serde(default)]
    pub sent_mean: f64,
}

impl LedgerSummary {
    fn new(ledger: &Ledger, end: SimTime) -> LedgerSummary {
        let stats = ledger.stats();
        LedgerSummary {
            geth_equivalent: geth::geth_equivalent(ledger, metrics::best_node(ledger), end),
            canonical_height: stats.canonical_height,
            forks: stats.forks_seen,
            reorgs: stats.reorgs,
            deepest_reorg: stats.deepest_reorg,
            tx_delay_median_s: stats.propagation.median_s,
            tx_delay_p95_s: stats.propagation.p95_s,
            bytes_per_submission: stats.bytes_per_submission,
            chain_bytes: stats
                .chain_bytes_samples
                .iter()
                .map(|s| ChainBytesPoint {
                    time_s: s.time_s,
                    mean: s.mean_bytes,
                    max: s.max_bytes as f64,
                    stored_mean: s.stored_mean_bytes,
                    sent_mean: s.sent_mean_bytes,
                })
                .collect(),
            details: stats,
        }
    }
}

/// Which robots are Byzantine and how, for `summary.json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ByzantineSummary {
    /// Their behaviour.
    pub kind: ByzantineKind,
    /// How many.
    pub count: u32,
    /// Their ids.
    pub robots: Vec<RobotId>,
    /// Their behaviour on the ledger.
    #[serde(default)]
    pub ledger: LedgerBehaviour,
}

/// Figures of a run for `summary.json` (the CLI adds wall-clock figures).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct RunSummary {
    /// Version of the records and of the hash chain ([`crate::log::RECORD_VERSION`]; the log
    /// file's layout version, which does not change the records or the final hash, is in the
    /// log's header).
    pub format: u32,
    /// The seed.
    pub seed: u64,
    /// The preset the configuration started from.
    pub preset: String,
    /// blake3 of the resolved configuration's TOML.
    pub config_hash: String,
    /// Simulated seconds.
    pub sim_time_s: f64,
    /// Number of robots.
    pub robots: u32,
    /// Records in the log.
    pub records: u64,
    /// Final hash of the log's chain.
    pub final_hash: String,
    /// The Byzantine robots.
    pub byzantine: ByzantineSummary,
    /// The world's figures.
    pub world: WorldStats,
    /// The ledger's figures.
    pub ledger: LedgerSummary,
    /// The contract's figures on the final canonical chain.
    pub contract: ContractSummary,
    /// Tokens per group at the end.
    pub tokens: TokenSummary,
    /// How models were aggregated, token conservation, and bytes sent and stored per robot.
    #[serde(default)]
    pub aggregation: AggregationSummary,
}

impl RunSummary {
    /// The summary of a finished run.
    pub fn new(
        config: &Config,
        seed: u64,
        state: &State,
        records: u64,
        final_hash: Digest,
    ) -> RunSummary {
        let byzantine = byzantine::byzantine_robots(config, seed);
        let (contract, tokens) = metrics::summarise(
            config,
            &state.ledger,
            &state.metrics,
            state.world.heldout(),
            &byzantine,
        );
        let (contract, aggregation) = match config.learn.aggregation {
            Aggregation::Chain => {
                let summary = aggregation::summary::chain_summary(
                    config,
                    &state.ledger.stats(),
                    contract
                        .final_heldout_loss
                        .unwrap_or(contract.heldout_loss_initial),
                );
                (contract, summary)
            }
            Aggregation::Gossip | Aggregation::Central | Aggregation::Matched => {
                aggregation::summary::summarise(
                    config,
                    &state.aggregation,
                    &state.metrics,
                    state.world.heldout(),
                    &byzantine,
                )
            }
        };
        RunSummary {
            format: crate::log::RECORD_VERSION,
            seed,
            preset: config.preset.clone(),
            config_hash: config.hash().to_hex().to_string(),
            sim_time_s: state.world.time().secs(),
            robots: config.world.robots,
            records,
            final_hash: final_hash.to_hex(),
            byzantine: ByzantineSummary {
                kind: config.byzantine.kind,
                count: config.byzantine.count,
                robots: (0..config.world.robots)
                    .filter(|&r| byzantine[r as usize])
                    .collect(),
                ledger: config.byzantine.ledger,
            },
            world: state.world.stats(),
            ledger: LedgerSummary::new(&state.ledger, state.world.time()),
            contract,
            tokens,
            aggregation,
        }
    }
}

//! The configuration tree: [`Config`] and its sections, one struct per table of the TOML
//! text, every field documented where it is declared, and what the rest of swarmfl derives
//! from them (ticks, rule in force, quorum, reward weights, the canonical text and its hash).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::behaviour::{
    Avoidance, Behaviour, FlockingConfig, ForagingConfig, HomeRangeConfig, MixedConfig, WindowRule,
};
use super::byzantine::{ByzantineKind, ByzantineVariant};
use super::contract::{
    ContractEngine, ContractOptions, Defence, FedAvgRounding, GasEstimateState, GasLimitRule,
    MedianRule, OutlierRule, PayoutRounding, PoolRule, RankKey, RankOrder, RankTies, RoundProtocol,
    Rule, ThresholdRule,
};
use super::ledger::LedgerBehaviour;
use super::preagg::{self, Preaggregator};
use super::skip::omit;
use super::timing::{AuthorsTimingConfig, Timing};
use crate::faults::FaultsConfig;

/// A complete, resolved configuration of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// The preset this configuration started from (informational; overrides may have changed it).
    pub preset: String,
    /// Simulated time.
    pub run: RunConfig,
    /// Arena, robots, physics and sensing (docs/SPEC.md section 1).
    pub world: WorldConfig,
    /// Trajectory data collection (docs/SPEC.md section 1, data collection).
    pub data: DataConfig,
    /// The model and its local training (docs/SPEC.md section 2).
    pub learn: LearnConfig,
    /// The per-robot blockchain nodes (docs/SPEC.md section 3).
    pub ledger: LedgerConfig,
    /// The federated-learning smart contract (docs/SPEC.md section 4).
    pub contract: ContractConfig,
    /// Byzantine robots (docs/SPEC.md section 5).
    pub byzantine: ByzantineConfig,
    /// Faults on the radio and the robots (none by default; beyond the paper).
    #[serde(default)]
    pub faults: FaultsConfig,
    /// Log and metrics settings (docs/SPEC.md sections 6 and 8).
    pub output: OutputConfig,
}

/// Simulated time of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Length of the run in simulated seconds (paper 5000, reference 4980).
    pub duration_s: f64,
    /// Simulation tick: the physics, sensing and data step (0.1 s = 10 Hz).
    pub tick_s: f64,
}

/// The arena, the robots, their controller and their sensors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldConfig {
    /// Number of robots in the swarm (every one a blockchain node).
    pub robots: u32,
    /// Side of the square, walled arena in metres (paper 5, reference 4), centered on the origin.
    pub arena_side_m: f64,
    /// Number of cylindrical obstacles.
    pub cylinders: u32,
    /// Radius of each cylinder in metres.
    pub cylinder_radius_m: f64,
    /// Number of box obstacles (square base, axis aligned).
    pub boxes: u32,
    /// Side of each box's square base in metres.
    pub box_side_m: f64,
    /// Obstacle centers are drawn uniformly in [-h, h]^2 with h this value (reference 1.5 m);
    /// 0 means "anywhere inside the walls" (paper).
    pub obstacle_spread_half_m: f64,
    /// Robot body radius in metres (Pi-puck: 0.035).
    pub robot_radius_m: f64,
    /// Distance between the two wheels in metres (Pi-puck: 0.053).
    pub wheel_base_m: f64,
    /// Forward speed of the random walk in m/s.
    pub cruise_speed_mps: f64,
    /// Number of IR proximity sensors, evenly spaced around the body.
    pub proximity_sensors: u32,
    /// Range of each proximity ray, measured from the body surface, in metres.
    pub proximity_range_m: f64,
    /// A front proximity reading above this value (0..1, 1 = touching) makes the robot turn away.
    pub proximity_threshold: f64,
    /// Probability per second that a free robot starts a random turn (the random walk).
    pub random_turn_rate_per_s: f64,
    /// Longest random turn in seconds (the duration is uniform in [0, this]).
    pub random_turn_max_s: f64,
    /// Range-and-bearing (and radio) range in metres (paper 2.5, reference 2.0).
    pub rab_range_m: f64,
    /// Standard deviation of the Gaussian noise on each axis of the measured offset, in metres.
    pub rab_noise_std_m: f64,
    /// Whether obstacles block the line of sight of range-and-bearing messages.
    pub rab_occlusion: bool,
    /// Probability that a range-and-bearing message is lost (per robot pair and tick).
    pub rab_packet_drop: f64,
    /// Period of the peer-set refresh in seconds: the node's peers are the robots in range.
    pub peer_refresh_s: f64,
    /// Whether other robots' bodies block range-and-bearing line of sight, as in ARGoS's
    /// range-and-bearing medium (the authors' and Flow-FL's simulator: a message passes only if
    /// the first body its ray meets is the receiver's). On in `paper`, hence in every preset
    /// (docs/SPEC.md section 1, "Data volume"); a recorded configuration without the key (made
    /// before it) reads as false, how it ran. This key and the four behaviour keys below are
    /// left out of the recorded text at their serde default, so a configuration that does not
    /// use them keeps the text, hence the hash chain, it had before the keys.
    #[serde(default, skip_serializing_if = "is_false")]
    pub rab_robot_occlusion: bool,
    /// The robots' controller: `avoidance` (default), `flocking`, `foraging` or `mixed`.
    #[serde(default, skip_serializing_if = "is_default")]
    pub behaviour: Behaviour,
    /// `mixed` only: which robot runs which behaviour.
    #[serde(default, skip_serializing_if = "is_default")]
    pub mixed: MixedConfig,
    /// The flocking controller's parameters.
    #[serde(default, skip_serializing_if = "is_default")]
    pub flocking: FlockingConfig,
    /// The foraging controller's nest, food sources and rest time.
    #[serde(default, skip_serializing_if = "is_default")]
    pub foraging: ForagingConfig,
    /// How robots sense and avoid obstacles: `turn` (serde default, ours before issue #38),
    /// `epuck` (the paper's code on ARGoS's e-puck; `paper`, hence every preset but `flowfl`)
    /// or `khepera` (Flow-FL's controller on ARGoS's Khepera IV; `flowfl`); docs/SPEC.md
    /// section 1, "Data volume". A recorded configuration without the key reads as `turn`,
    /// how it ran.
    #[serde(default, skip_serializing_if = "is_default")]
    pub avoidance: Avoidance,
    /// Whether a robot whose translation would overlap something slides along it (ARGoS's
    /// dynamics2d, the authors' and Flow-FL's simulator) instead of staying put
    /// (`world/physics.rs`). On in `paper`, hence in every preset; a recorded configuration
    /// without the key reads as false, how it ran.
    #[serde(default, skip_serializing_if = "is_false")]
    pub slide_on_contact: bool,
    /// The avoidance walk's home ranges (`alpha = "inf"`, the default: none, today's roaming
    /// swarm). Left out of the recorded text at its default, so records keep their hashes.
    #[serde(default, skip_serializing_if = "is_default")]
    pub home_range: HomeRangeConfig,
}

/// Trajectory recording and the data set of each robot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataConfig {
    /// Consecutive ticks of one neighbour that form a trajectory (100 = 10 s).
    pub trajectory_ticks: u32,
    /// Waypoints of the model's input (0..32 = 3.2 s).
    pub input_waypoints: u32,
    /// Waypoints of the model's target (32..80 = 4.8 s); the rest of the trajectory is unused.
    pub target_waypoints: u32,
    /// Samples older than this many seconds are dropped from the robot's data set.
    pub expiration_s: f64,
    /// Number of noise-free trajectories the ground-truth observer collects as a held-out set.
    pub heldout_samples: u32,
    /// Observation windows the held-out set is drawn from, spread over the run, at every swarm
    /// size (`world/mod.rs`, `heldout_window_starts`): each window holds up to
    /// `ceil(heldout_samples / windows)` samples from robots spread over the swarm. A swarm too
    /// small to fill them gets `ceil(heldout_samples / robots)` windows of every robot, as
    /// before the key (so 15 robots and fewer keep their sets); 0 takes that rule at every size
    /// (the set of records made before the key, one window at 240 robots). Default 14.
    #[serde(
        default = "default_heldout_windows",
        skip_serializing_if = "is_default_heldout_windows"
    )]
    pub heldout_windows: u32,
    /// When a window becomes a sample: `confirmed` (the authors' code; `paper`, hence every
    /// preset) or `contiguous` (docs/SPEC.md section 1, "Data volume"). A recorded
    /// configuration without the key (made before it) reads as `contiguous`, how it ran; the
    /// key is left out of the recorded text at that value, so such records keep their hashes.
    #[serde(default, skip_serializing_if = "is_default")]
    pub window_rule: WindowRule,
}

/// The model and local training.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LearnConfig {
    /// LSTM units (the paper's model has 16).
    pub lstm_units: u32,
    /// Dropout rate after the LSTM layer, active during training only.
    pub dropout: f64,
    /// SGD learning rate: 0.01, what the authors' code ran (Keras' default); the paper's text says
    /// 0.001 (preset `paper-text`). docs/SPEC.md section 2 has the evidence.
    pub learning_rate: f64,
    /// Mini-batch size.
    pub batch_size: u32,
    /// Passes over the training split per local training.
    pub epochs: u32,
    /// Fraction of the (chronological) data set used for training; the rest validates.
    pub train_fraction: f64,
    /// Period of a robot's training phase in simulated seconds.
    pub training_period_s: f64,
    /// Simulated time a local training takes before the model is submitted (paper: 0).
    pub training_duration_s: f64,
    /// Fewest training samples a robot needs before it trains and submits.
    pub min_train_samples: u32,
    /// How the robots' models are aggregated: through the blockchain (`chain`, the paper's
    /// system), Flow-FL-style gossip of a virtual-stigmergy store (`gossip`) or an ideal
    /// central server (`central`). See `aggregation` (ARCHITECTURE.md) for the baselines.
    #[serde(default)]
    pub aggregation: Aggregation,
    /// `gossip` only: a robot leaves out of its average the stored models whose mean absolute
    /// weight distance to its own current model exceeds `contract.outlier_threshold`
    /// (Flow-FL has no such filter: off by default).
    #[serde(default)]
    pub gossip_outlier_filter: bool,
    /// The coordinates the model reads and predicts: `world` (the paper's: world metres) or
    /// `relative` (every waypoint of a sample minus its last input waypoint, the usual frame of
    /// trajectory predictors such as Social LSTM). A translation leaves MSE unchanged, so losses
    /// stay in square metres of position error in both; `relative` makes the task the same in
    /// every arena, which a 40 m arena needs (issue 32, RESEARCH.md). Left out of the recorded
    /// configuration at its default, so existing runs keep their hashes.
    #[serde(default, skip_serializing_if = "is_default")]
    pub frame: Frame,
    /// The learning schedule's timing model: `independent` (swarmfl's: every robot on its own
    /// uniform phase, start to start; the default) or `authors` (the authors' code: the
    /// Byzantine robots in step, the honest robots' trainings queued at one server, end to
    /// start; `learn.authors_timing`). Chain aggregation only. Left out of the recorded text
    /// at its default, so records keep their hashes.
    #[serde(default, skip_serializing_if = "is_default")]
    pub timing: Timing,
    /// The authors' timing's jitter and server time (read under `learn.timing = "authors"`).
    /// Left out of the recorded text at its default.
    #[serde(default, skip_serializing_if = "is_default")]
    pub authors_timing: AuthorsTimingConfig,
    /// Robots that never submit a model: they move, record data and seal blocks, but take no
    /// learning phase (no training, no report, no submission). The counterfactual of
    /// `swarmfl blame` and `contributions` ("the run without robot k's submissions"). Empty
    /// (the default) and then left out of the recorded configuration, so no record moves.
    #[serde(default, skip_serializing_if = "is_empty")]
    pub withheld: Vec<u32>,
}

/// The coordinates of the model's inputs and targets (`learn.frame`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Frame {
    /// World metres, as recorded (the paper's).
    #[default]
    World,
    /// Each sample's waypoints minus its last input waypoint.
    Relative,
}

impl Frame {
    /// The name used in configurations.
    pub fn name(self) -> &'static str {
        match self {
            Frame::World => "world",
            Frame::Relative => "relative",
        }
    }
}

/// How the robots' trained models become their next starting model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Aggregation {
    /// Transactions to the smart contract on every robot's chain (the paper's system).
    #[default]
    Chain,
    /// Flow-FL: a virtual-stigmergy store replicated by neighbour gossip; each robot averages
    /// the newest models it holds.
    Gossip,
    /// An ideal server that receives every model instantly and aggregates FedAvg.
    Central,
    /// The matched ideal of the buffered protocol (`aggregation/matched.rs`): a server that
    /// receives every update instantly and applies the buffered rule to every
    /// `contract.buffer_size` of them, without delay, staleness bound or outlier check.
    Matched,
}

impl Aggregation {
    /// The name used in configurations and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Aggregation::Chain => "chain",
            Aggregation::Gossip => "gossip",
            Aggregation::Central => "central",
            Aggregation::Matched => "matched",
        }
    }
}

/// The per-robot proof-of-authority nodes and the radio between them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LedgerConfig {
    /// Minimum time between a block and its child in seconds (Clique period).
    pub block_period_s: f64,
    /// Unit of the out-of-turn sealing delay: delays are uniform in [0, (N/2 + 1) * this).
    pub wiggle_unit_s: f64,
    /// Per-link bandwidth in bytes per second; 0 means unlimited.
    pub bandwidth_bytes_per_s: u64,
    /// Probability that a gossip message between two peers is lost.
    pub packet_loss: f64,
}

/// The round deadline every preset sets (`contract.round_timeout_s`), in seconds: longer than
/// any round of the paper's experiments (measured on the fixtures and on `paper`, `e1-*`,
/// `e2-*`, `e3-*`: see `contract/deadline.rs`), so it never fires in them and their records
/// do not move, yet a stalled round releases its stakes within one run.
pub const DEFAULT_ROUND_TIMEOUT_S: f64 = 1800.0;

/// The federated-learning contract.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContractConfig {
    /// Security mechanisms (stake, outlier rejection, ranking, rewards) on or off (Exp. 1: off).
    pub security: bool,
    /// Tokens every robot holds at genesis.
    pub initial_tokens: u64,
    /// Tokens staked with every submission (Sybil protection).
    pub stake_tokens: u64,
    /// Integer units per token (balances are integers of this unit).
    pub token_units: u64,
    /// Fixed-point scale of on-chain weights (1e9, as the reference's int48).
    pub weight_scale: u64,
    /// Quorum fraction q: an aggregation needs max(floor(q * N_r), 1) accepted models.
    pub quorum_fraction: f64,
    /// Outlier threshold on the mean absolute weight distance to the shared model.
    pub outlier_threshold: f64,
    /// How many of the quorum's ranks are penalised (weight -1, the worst ranks); the others
    /// are rewarded (+1). The paper's k = [1, 1, 1, 1, 1, -1, -1] is 2 of 7.
    pub penalised_ranks: u32,
    /// The aggregation rule (`fedavg`, `paper`, `krum`, `multi-krum`, `median`,
    /// `trimmed-mean`, `geomed`, `centered-clipping`, `bulyan`, `mda`, `meamed`, `monna`,
    /// `signguard`, `dnc`, or `plugin` for one named by `rule_plugin`; see `contract::rules`).
    /// `security = false` means `fedavg` whatever this says (old configurations read as before).
    #[serde(default = "default_rule")]
    pub rule: Rule,
    /// `rule_plugin`: the name of the plug-in aggregation rule (`contract.rule = "plugin"`),
    /// which the program running the simulation supplies (the Python package's
    /// `swarmfl.run(rule=...)`); empty otherwise. Left out of the recorded configuration when
    /// empty, so the records of every other rule do not move.
    #[serde(default, skip_serializing_if = "is_default")]
    pub rule_plugin: String,
    /// Byzantine submissions per round the robust rules assume (f): krum and multi-krum need
    /// quorum >= 2f + 3, median, trimmed-mean, geomed, centered-clipping, mda, meamed, monna,
    /// signguard and dnc 2f + 1, bulyan 4f + 3 (and mda at most 2^20 subsets C(quorum, f)).
    /// Ignored by fedavg and paper (and read by signguard only for its quorum).
    #[serde(default = "default_assumed_f")]
    pub assumed_f: u32,
    /// A round that has not reached its quorum this many seconds (block time) after it opened
    /// closes without aggregation and refunds the stakes of its accepted submissions; 0 = never.
    /// Beyond the paper, whose contract has no deadline. Every preset sets
    /// [`DEFAULT_ROUND_TIMEOUT_S`], a value no round of the paper's experiments reaches (see
    /// `contract/deadline.rs`), so a stalled round cannot lock its stakes for good; a recorded
    /// configuration without the key (older logs) reads as 0, as those runs had no deadline.
    #[serde(default)]
    pub round_timeout_s: f64,
    /// The most samples one submission may claim; a larger claim is refused by the contract
    /// (malformed, no stake taken, the reason recorded). 0 (the default, in every preset and
    /// for a recorded configuration without the key) derives the bound from what a robot can
    /// physically collect in its data window: `(world.robots - 1)` neighbours, each giving at
    /// most one sample per `data.trajectory_ticks` ticks, kept `data.expiration_s`, of which
    /// the learner trains on the `learn.train_fraction` split (see `contract/claims.rs`; 851
    /// for `paper`). A number sets the bound explicitly (1..=4294967295; 4294967295 is the
    /// contract's hard limit, i.e. no bound). Beyond the paper: the authors' contract has none.
    #[serde(default)]
    pub max_claimed_samples: u64,
    /// Explicit reward weight per rank, best first (one per quorum rank, at least one
    /// positive, each in -1000..=1000); empty (the default) derives them from
    /// `penalised_ranks`. The authors' contract comments [5, 4, 3, 2, 1, -1, -2].
    #[serde(default)]
    pub reward_weights: Vec<i64>,
    /// Which machine executes the contract: `native` (the Rust reducer) or `evm` (the Solidity
    /// contract of `contracts/`, its committed bytecode run in revm; same events and results).
    #[serde(default)]
    pub engine: ContractEngine,
    /// Median of an even count of distances: `lower` middle (swarmfl) or `mean` of the two
    /// middles, floored (authors).
    #[serde(default)]
    pub median: MedianRule,
    /// FedAvg rounding: `nearest`, ties away from zero (swarmfl), or `truncate` toward zero
    /// (authors).
    #[serde(default)]
    pub fedavg_rounding: FedAvgRounding,
    /// Refuse (malformed) an accepted model when some `w_i * n`, or the round's running sum
    /// with it, leaves int48: the authors' int48 accumulator reverts such a submission.
    #[serde(default)]
    pub int48_products: bool,
    /// Outlier threshold: `inclusive`, `d <= t * N` (swarmfl), or `strict`, `d < t * N`
    /// (authors).
    #[serde(default)]
    pub threshold: ThresholdRule,
    /// Ranking key: exact L1 `distance` (swarmfl) or truncated `mae` `floor(d / N)` (authors).
    #[serde(default)]
    pub rank_key: RankKey,
    /// Ranking ties: `stable` submission order (swarmfl) or the authors' `quicksort`.
    #[serde(default)]
    pub rank_ties: RankTies,
    /// Ranking order of the paper's rule (beyond the paper; issue #36, the counterfactual of
    /// claim 12): `median`, closest to the median distance first (the paper's), or `nearest`,
    /// closest to the shared model first, so that no rank depends on where the round's other
    /// models put the median (`contract/rank_order.rs`). Native engine only. Left out of the
    /// recorded configuration at its default, so existing runs keep their hashes.
    #[serde(default, skip_serializing_if = "is_default")]
    pub rank_order: RankOrder,
    /// Payout shares: `exact` to one unit (swarmfl) or `ratio_1e9`, normalised to 1e9 and
    /// floored (authors).
    #[serde(default)]
    pub payout_rounding: PayoutRounding,
    /// Pool of an aggregation: `carry` (all the contract holds, remainders included; swarmfl)
    /// or `round` (the round's stakes only; authors).
    #[serde(default)]
    pub pool: PoolRule,
    /// A defence of the reward rule against robots that are paid without collecting data or
    /// training (issue 16, beyond the paper): `none` (the rule's own rewards), `agreement` or
    /// `innovation` (rewards follow a model's agreement with the round's other models; see
    /// `contract::defences`). Needs a staking rule (security on); `none` in every preset but
    /// `e5-smart-defence`.
    #[serde(default)]
    pub defence: Defence,
    /// Percent (0..=100) of an aggregation's pool that a defence refunds in equal parts to the
    /// used submissions; the rest is shared by score.
    #[serde(default = "default_defence_refund_percent")]
    pub defence_refund_percent: u32,
    /// The most gas one block holds, under `engine = "evm"` (the native engine has no gas): a
    /// call that needs more can never be included, so the contract refuses it (outcome
    /// `over_gas_limit`, its state unchanged, counted in the summary's submissions by
    /// outcome). Default: the authors' genesis, 0x9000000000000 = 2533274790395904
    /// (`TrajectoryPrediction/reset-geth` of github.com/teksander/geth-argos); Ethereum
    /// mainnet's 30000000 refuses the paper's submissions (docs/CONTRACT.md, "Gas"). Left
    /// out of the recorded configuration at its default, so existing runs keep their hashes.
    #[serde(
        default = "default_block_gas_limit",
        skip_serializing_if = "is_default_block_gas_limit"
    )]
    pub block_gas_limit: u64,
    /// The gas limit of a robot's transaction, under `engine = "evm"`: `block` (every call may
    /// use the block's, `block_gas_limit`; swarmfl's default) or `estimate` (the authors' web3:
    /// the gas the call uses on the state its node holds when the robot sends it, plus
    /// `gas_margin`; a call that then needs more runs out of gas and reverts, outcome
    /// `out_of_gas`; docs/CONTRACT.md, "Gas"). Left out of the recorded configuration at its
    /// default, so existing runs keep their hashes.
    #[serde(default, skip_serializing_if = "is_default")]
    pub gas_limit: GasLimitRule,
    /// The gas added to the estimate under `gas_limit = "estimate"`: web3.py's buffer,
    /// 100000 (`get_buffered_gas_estimate`). Left out of the recorded configuration at its
    /// default.
    #[serde(
        default = "default_gas_margin",
        skip_serializing_if = "is_default_gas_margin"
    )]
    pub gas_margin: u64,
    /// The state the estimate runs on under `gas_limit = "estimate"`: `pending` (the block the
    /// sender's node would seal next: its head, then the transactions of its mempool that
    /// block would take; geth's default for `eth_estimateGas`, as web3.py calls it) or `head`
    /// (the head block's state alone). Left out of the recorded configuration at its default.
    #[serde(default, skip_serializing_if = "is_default")]
    pub gas_estimate_state: GasEstimateState,
    /// How often, in seconds, a node's miner rebuilds its pending block when transactions
    /// arrived (geth's `--miner.recommit`, 3 s), under `gas_estimate_state = "pending"`; the
    /// block is also rebuilt at each new head. 0: on every arrival. Left out of the recorded
    /// configuration at its default.
    #[serde(
        default = "default_gas_recommit_s",
        skip_serializing_if = "is_default_gas_recommit_s"
    )]
    pub gas_recommit_s: f64,
    /// Pre-aggregation stages in front of the rule, applied in list order (`nnm`,
    /// `bucketing`, `clipping`, `arc`; see `contract::preagg`), e.g. `["nnm"]`. Needs a staking
    /// rule on the native contract; the rule then runs on the stages' output, the rewards stay
    /// on the submissions made (docs/CONTRACT.md). Empty (the default): the rule alone.
    #[serde(default, skip_serializing_if = "is_empty")]
    pub preaggregators: Vec<Preaggregator>,
    /// The paper's outlier threshold in front of a robust rule: a submission farther than
    /// `outlier_threshold` (mean absolute distance per weight) from the shared model is refused
    /// as an outlier and its stake kept, as under `paper`, and the robust rule (behind any
    /// pre-aggregators) aggregates the round's accepted models. Needs a robust rule (`paper`
    /// has the threshold already, `fedavg` stakes nothing) on the native contract (RESEARCH.md,
    /// "The threshold in front of a robust rule"). Off by default, and then left out of the
    /// recorded configuration.
    #[serde(default, skip_serializing_if = "is_false")]
    pub threshold_gate: bool,
    /// `bucketing`: models per bucket, `s` (1..=quorum; 2 by default; the last bucket holds the
    /// remainder when `s` does not divide the quorum).
    #[serde(
        default = "preagg::default_bucket_size",
        skip_serializing_if = "preagg::is_default_bucket_size"
    )]
    pub bucket_size: u32,
    /// `clipping`: the radius, in weight units, of the L2 norm of an update `w_k - w(t)`
    /// beyond which it is scaled back onto the sphere (in (0, 1e6]; 1.0 by default).
    #[serde(
        default = "preagg::default_clip_radius",
        skip_serializing_if = "preagg::is_default_clip_radius"
    )]
    pub clip_radius: f64,
    /// How submissions become model versions: `rounds` (the paper's, the default) or
    /// `buffered` (issue 32: a submission names the version it trained from, is judged
    /// against it, and every `buffer_size` accepted updates move the model by their sample-
    /// and staleness-weighted mean; `contract/buffered.rs`, docs/CONTRACT.md). Left out of
    /// the recorded configuration at its default, so existing runs keep their hashes.
    #[serde(default, skip_serializing_if = "is_default")]
    pub protocol: RoundProtocol,
    /// `buffered`: accepted updates per model version, K (1..=world.robots; 7 by default, the
    /// paper's quorum, whatever the swarm's size). Replaces the quorum of `quorum_fraction`,
    /// so `penalised_ranks` and `reward_weights` count buffer ranks.
    #[serde(
        default = "default_buffer_size",
        skip_serializing_if = "is_default_buffer_size"
    )]
    pub buffer_size: u32,
    /// `buffered`: the oldest base a submission may name, in versions behind the newest
    /// (0..=1000; 64 by default): an older one is refused as stale, its stake untouched.
    /// Every node keeps the last `max_staleness` versions to judge submissions against them.
    #[serde(
        default = "default_max_staleness",
        skip_serializing_if = "is_default_max_staleness"
    )]
    pub max_staleness: u32,
    /// `buffered`: FedAsync's staleness exponent a, weight `(1 + tau)^-a` of an update
    /// trained `tau` versions ago (0..=10; 0.5 by default; 0 weighs every update alike).
    #[serde(
        default = "default_staleness_exponent",
        skip_serializing_if = "is_default_staleness_exponent"
    )]
    pub staleness_exponent: f64,
    /// `buffered`: the server step size eta: the model moves by eta times the weighted mean
    /// update (in (0, 10]; 1 by default, FedBuff's plain mean).
    #[serde(
        default = "default_server_step",
        skip_serializing_if = "is_default_server_step"
    )]
    pub server_step: f64,
    /// `buffered`: how the outlier check sets its bound (beyond the paper, issue #32;
    /// `contract/outlier.rs`): `absolute` (the paper's `outlier_threshold`, the default) or
    /// `relative` (`outlier_factor` times the median distance of the accepted updates of the
    /// last `outlier_window` closed buffers, within [`outlier_threshold`, `outlier_cap`]), so
    /// the bound follows the honest spread where honest updates are larger than the paper's.
    /// Native engine and `rule = paper` only. Left out of the recorded configuration at its
    /// default, so existing runs keep their hashes.
    #[serde(default, skip_serializing_if = "is_default")]
    pub outlier_rule: OutlierRule,
    /// `relative`: k, the bound's multiple of the median accepted distance (in (0, 1000]; 5
    /// by default, the paper's own margin: its 0.05 is 5x the pilot study's honest distance).
    #[serde(
        default = "default_outlier_factor",
        skip_serializing_if = "is_default_outlier_factor"
    )]
    pub outlier_factor: f64,
    /// `relative`: the closed buffers whose accepted distances the median is taken over
    /// (1..=1024; 8 by default, 8K = 56 updates); until that many have closed the bound is
    /// `outlier_threshold`.
    #[serde(
        default = "default_outlier_window",
        skip_serializing_if = "is_default_outlier_window"
    )]
    pub outlier_window: u32,
    /// `relative`: the largest bound, a mean absolute distance (in [`outlier_threshold`,
    /// 1e6]; 0.2 by default, below the 0.25 of a model drawn uniformly in [-0.5, 0.5)).
    #[serde(
        default = "default_outlier_cap",
        skip_serializing_if = "is_default_outlier_cap"
    )]
    pub outlier_cap: f64,
}

/// `contract.outlier_factor`'s default: the paper's 0.05 over its pilot study's honest
/// distance, about 0.01 (docs/SPEC.md section 4).
pub fn default_outlier_factor() -> f64 {
    5.0
}

fn is_default_outlier_factor(k: &f64) -> bool {
    omit(*k == default_outlier_factor())
}

/// `contract.outlier_window`'s default, in closed buffers (see `contract/outlier.rs`).
pub fn default_outlier_window() -> u32 {
    8
}

fn is_default_outlier_window(w: &u32) -> bool {
    omit(*w == default_outlier_window())
}

/// `contract.outlier_cap`'s default (see `contract/outlier.rs`).
pub fn default_outlier_cap() -> f64 {
    0.2
}

fn is_default_outlier_cap(cap: &f64) -> bool {
    omit(*cap == default_outlier_cap())
}

/// `data.heldout_windows`'s default: the 14 windows of the paper's 200 samples of 15 robots.
pub fn default_heldout_windows() -> u32 {
    14
}

fn is_default_heldout_windows(w: &u32) -> bool {
    omit(*w == default_heldout_windows())
}

/// `contract.buffer_size`'s default: the paper's quorum of 7.
pub fn default_buffer_size() -> u32 {
    7
}

fn is_default_buffer_size(k: &u32) -> bool {
    omit(*k == default_buffer_size())
}

/// `contract.max_staleness`'s default (see `contract/buffered.rs` for the reason).
pub fn default_max_staleness() -> u32 {
    64
}

fn is_default_max_staleness(v: &u32) -> bool {
    omit(*v == default_max_staleness())
}

/// `contract.staleness_exponent`'s default: FedAsync's a = 0.5.
pub fn default_staleness_exponent() -> f64 {
    0.5
}

fn is_default_staleness_exponent(a: &f64) -> bool {
    omit(*a == default_staleness_exponent())
}

/// `contract.server_step`'s default: 1.
pub fn default_server_step() -> f64 {
    1.0
}

fn is_default_server_step(eta: &f64) -> bool {
    omit(*eta == default_server_step())
}

fn default_defence_refund_percent() -> u32 {
    50
}

/// The authors' genesis gas limit (`contract.block_gas_limit`'s default): their
/// `reset-geth` replaces puppeth's 0x47b760 (4.7M) with 0x9000000000000.
pub const AUTHORS_BLOCK_GAS_LIMIT: u64 = 0x9000000000000;

/// `contract.block_gas_limit`'s default, [`AUTHORS_BLOCK_GAS_LIMIT`].
pub fn default_block_gas_limit() -> u64 {
    AUTHORS_BLOCK_GAS_LIMIT
}

fn is_false(b: &bool) -> bool {
    omit(!*b)
}

fn is_default<T: Default + PartialEq>(value: &T) -> bool {
    omit(*value == T::default())
}

fn is_empty<T>(list: &[T]) -> bool {
    omit(list.is_empty())
}

fn is_default_block_gas_limit(limit: &u64) -> bool {
    omit(*limit == AUTHORS_BLOCK_GAS_LIMIT)
}

/// web3.py's gas buffer over an estimate (`contract.gas_margin`'s default).
pub const WEB3_GAS_MARGIN: u64 = 100_000;

/// `contract.gas_margin`'s default, [`WEB3_GAS_MARGIN`].
pub fn default_gas_margin() -> u64 {
    WEB3_GAS_MARGIN
}

fn is_default_gas_margin(margin: &u64) -> bool {
    omit(*margin == WEB3_GAS_MARGIN)
}

/// geth's `--miner.recommit` default, 3 s (`contract.gas_recommit_s`'s default).
pub const GETH_RECOMMIT_S: f64 = 3.0;

/// `contract.gas_recommit_s`'s default, [`GETH_RECOMMIT_S`].
pub fn default_gas_recommit_s() -> f64 {
    GETH_RECOMMIT_S
}

#[allow(clippy::float_cmp)]
fn is_default_gas_recommit_s(s: &f64) -> bool {
    omit(*s == GETH_RECOMMIT_S)
}

impl ContractConfig {
    /// The variant options of the contract (docs/CONTRACT.md).
    pub fn options(&self) -> ContractOptions {
        ContractOptions {
            median: self.median,
            fedavg_rounding: self.fedavg_rounding,
            int48_products: self.int48_products,
            threshold: self.threshold,
            rank_key: self.rank_key,
            rank_ties: self.rank_ties,
            rank_order: self.rank_order,
            payout_rounding: self.payout_rounding,
            pool: self.pool,
        }
    }
}

fn default_rule() -> Rule {
    Rule::Paper
}

fn default_assumed_f() -> u32 {
    1
}

/// Which robots are Byzantine and how they behave.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ByzantineConfig {
    /// Behaviour of the Byzantine robots: one of [`ByzantineKind`] (`none`, `faulty`,
    /// `malicious`, `smart`, ...).
    pub kind: ByzantineKind,
    /// How many robots are Byzantine (they replace honest ones: the swarm size stays).
    pub count: u32,
    /// Formula variant: the paper's (`paper`), our reading of the reference implementation
    /// (`reference`) or the authors' code as it runs (`authors`: `smart` adds 2 r Delta and
    /// extrapolates its first submission from all-zero weights).
    pub variant: ByzantineVariant,
    /// Samples a Byzantine robot claims with each submission (reference: 200).
    pub claimed_samples: u32,
    /// Faulty robots send weights uniform in [-this, this].
    pub faulty_range: f64,
    /// How many honest submissions of the current round the attacks that read them (`alie`,
    /// `ipm`, `min-max`, `mimic`, `inflate-samples`) wait to see on their own chain before
    /// submitting (at least 1; `alie` and `min-max` use at least 2).
    #[serde(default = "default_wait_for_honest")]
    pub wait_for_honest: u32,
    /// `sign-flip`: the submitted model is w(t) - scale * (w(t) - w(t-1)); `ipm`: the
    /// submitted step is -scale times the honest mean step (inner-product manipulation's
    /// epsilon).
    #[serde(default = "default_attack_scale")]
    pub scale: f64,
    /// `gaussian`: standard deviation of the noise added to every weight of w(t).
    #[serde(default = "default_sigma")]
    pub sigma: f64,
    /// `alie`: how many honest standard deviations each weight is moved from the honest mean.
    #[serde(default = "default_alie_z")]
    pub alie_z: f64,
    /// `inflate-samples` and `collude`: the fraction of the outlier threshold
    /// (`contract.outlier_threshold`, mean absolute distance) the forged model moves from w(t).
    #[serde(default = "default_threshold_fraction")]
    pub threshold_fraction: f64,
    /// `inflate-samples`: the sample count claimed (the contract's limit is 2^32 - 1).
    #[serde(default = "default_inflated_samples")]
    pub inflated_samples: u32,
    /// Misbehaviour of the same robots on the ledger (sealing, gossip, transactions),
    /// orthogonal to `kind` (beyond the paper; `honest` by default): one of
    /// [`LedgerBehaviour`].
    #[serde(default)]
    pub ledger: LedgerBehaviour,
    /// `smart-then-collude`: the share of the robots' tokens (balances on the robot's own
    /// chain, Byzantine over all) above which the Byzantine robots stop acting `smart` and
    /// all submit one harmful model; 0.5 = "more tokens than the honest robots together".
    #[serde(default = "default_switch_token_share")]
    pub switch_token_share: f64,
    /// `optimal-alie` and `optimal-ipm`: evaluations of the contract's aggregation per line
    /// search of the attack factor (1..=1000; 20 by default, as ByzFL). Left out of the
    /// recorded configuration at its default.
    #[serde(
        default = "default_search_evals",
        skip_serializing_if = "is_default_search_evals"
    )]
    pub search_evals: u32,
    /// `plugin`: the name of the plug-in attack (`byzantine.kind = "plugin"`), which the
    /// program running the simulation supplies (the Python package's `swarmfl.run(attack=...)`);
    /// empty otherwise. Left out of the recorded configuration when empty.
    #[serde(default, skip_serializing_if = "is_default")]
    pub plugin: String,
    /// Byzantine robots (of those `count` draws) that train and submit as honest robots do:
    /// the "as if honest" counterfactual of `swarmfl blame`. They stay in the Byzantine set
    /// that summaries and predicates group by. Empty (the default) and then left out of the
    /// recorded configuration.
    #[serde(default, skip_serializing_if = "is_empty")]
    pub as_honest: Vec<u32>,
}

fn default_search_evals() -> u32 {
    20
}

fn is_default_search_evals(n: &u32) -> bool {
    omit(*n == default_search_evals())
}

fn default_switch_token_share() -> f64 {
    0.5
}

fn default_wait_for_honest() -> u32 {
    2
}

fn default_attack_scale() -> f64 {
    1.0
}

fn default_sigma() -> f64 {
    0.1
}

fn default_alie_z() -> f64 {
    1.0
}

fn default_threshold_fraction() -> f64 {
    0.99
}

fn default_inflated_samples() -> u32 {
    u32::MAX
}

/// Log and metrics settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputConfig {
    /// Block lookups on the run's log keep the full reduced state in memory right after every
    /// this many blocks of the final canonical chain that they fold past, and a later lookup of
    /// the same log starts from the nearest one at or before its block instead of folding from
    /// genesis (`inspect::Seeker`: the Python package's `Run.at(block=...)`; 0 = keep none).
    /// Read from the log's header. Nothing is written: the run's records are the same for every
    /// value (the value is part of the recorded configuration text, so it stays in it).
    pub snapshot_every_blocks: u32,
}

impl Config {
    /// Number of simulation ticks of the run.
    pub fn ticks(&self) -> u64 {
        (self.run.duration_s / self.run.tick_s).round() as u64
    }

    /// The aggregation rule in force: `fedavg` when `contract.security` is off, else
    /// `contract.rule`.
    pub fn rule(&self) -> Rule {
        if self.contract.security {
            self.contract.rule
        } else {
            Rule::Fedavg
        }
    }

    /// The quorum: max(floor(q * N_r), 1); under `contract.protocol = "buffered"` the buffer
    /// size K (the accepted submissions one aggregation takes).
    pub fn quorum(&self) -> u32 {
        if self.contract.protocol == RoundProtocol::Buffered {
            // At least 1 so that the table of checks can be built before
            // `contract.buffer_size = 0` is refused.
            return self.contract.buffer_size.max(1);
        }
        ((self.contract.quorum_fraction * f64::from(self.world.robots)).floor() as u32).max(1)
    }

    /// The reward weight of each rank, best first: +1 for the rewarded, -1 for the
    /// `penalised_ranks` worst (paper: [1, 1, 1, 1, 1, -1, -1]).
    pub fn reward_weights(&self) -> Vec<i64> {
        if !self.contract.reward_weights.is_empty() {
            return self.contract.reward_weights.clone();
        }
        let q = self.quorum() as usize;
        // At least the best rank is rewarded (validation enforces it; the clamp keeps
        // unvalidated test configurations meaningful).
        let p = (self.contract.penalised_ranks as usize).min(q - 1);
        (0..q)
            .map(|rank| if rank + p < q { 1 } else { -1 })
            .collect()
    }

    /// The TOML text of this configuration as runs record it (keys added after records
    /// existed are left out at their default: see [`Config::to_toml_full`]).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a Config always serialises to TOML")
    }

    /// The blake3 hash of the canonical TOML text: names a configuration in results.
    pub fn hash(&self) -> blake3::Hash {
        blake3::hash(self.to_toml().as_bytes())
    }

    /// Every leaf of the configuration as `dotted.key -> value as TOML text`, sorted by key.
    pub fn flat_values(&self) -> BTreeMap<String, String> {
        toml_leaves(&toml::Value::try_from(self).expect("Config serialises"))
    }

    /// The dotted keys whose values differ between `self` and `other`, sorted.
    pub fn changed_keys(&self, other: &Config) -> Vec<String> {
        let (a, b) = (self.flat_values(), other.flat_values());
        let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
        keys.into_iter()
            .filter(|k| a.get(*k) != b.get(*k))
            .cloned()
            .collect()
    }
}

/// Every leaf of a TOML tree (a value that is not a table) as `dotted.key -> value as TOML
/// text`, sorted by key: `world.robots -> 15`, `faults.partitions -> [...]`.
pub(crate) fn toml_leaves(tree: &toml::Value) -> BTreeMap<String, String> {
    fn walk(prefix: &str, value: &toml::Value, out: &mut BTreeMap<String, String>) {
        match value {
            toml::Value::Table(t) => {
                for (k, v) in t {
                    let key = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&key, v, out);
                }
            }
            v => {
                out.insert(prefix.to_string(), v.to_string());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk("", tree, &mut out);
    out
}

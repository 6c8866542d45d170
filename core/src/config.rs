//! The configuration: one serde tree holding every parameter of the system, with its default.
//!
//! Every number of docs/SPEC.md is a field here, documented where it is declared. A run is fully
//! determined by a [`Config`] and a seed. Configurations come from a named preset
//! ([`Preset`]), optionally overlaid with a TOML file and with `key.path=value` overrides
//! ([`Config::set`]); [`Config::validate`] then checks every range and names the offending key.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

pub use crate::byzantine::ledger::LedgerBehaviour;
pub use crate::contract::defences::Defence;
use crate::contract::options::ContractOptions;
pub use crate::contract::options::{
    ContractEngine, FedAvgRounding, MedianRule, PayoutRounding, PoolRule, RankKey, RankTies,
    ThresholdRule,
};
pub use crate::contract::rules::Rule;
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
    /// Side of the square, walled arena in metres (paper 5, reference 4), centred on the origin.
    pub arena_side_m: f64,
    /// Number of cylindrical obstacles.
    pub cylinders: u32,
    /// Radius of each cylinder in metres.
    pub cylinder_radius_m: f64,
    /// Number of box obstacles (square base, axis aligned).
    pub boxes: u32,
    /// Side of each box's square base in metres.
    pub box_side_m: f64,
    /// Obstacle centres are drawn uniformly in [-h, h]^2 with h this value (reference 1.5 m);
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
}

impl Aggregation {
    /// The name used in configurations and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Aggregation::Chain => "chain",
            Aggregation::Gossip => "gossip",
            Aggregation::Central => "central",
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
    /// `trimmed-mean`, `geomed`, `centered-clipping`, `bulyan`; see `contract::rules`).
    /// `security = false` means `fedavg` whatever this says (old configurations read as before).
    #[serde(default = "default_rule")]
    pub rule: Rule,
    /// Byzantine submissions per round the robust rules assume (f): krum and multi-krum need
    /// quorum >= 2f + 3, median, trimmed-mean, geomed and centered-clipping 2f + 1, bulyan
    /// 4f + 3. Ignored by fedavg and paper.
    #[serde(default = "default_assumed_f")]
    pub assumed_f: u32,
    /// A round that has not reached its quorum this many seconds (block time) after it opened
    /// closes without aggregation and refunds the stakes of its accepted submissions; 0 = never.
    /// Beyond the paper, whose contract has no deadline: off in every preset.
    #[serde(default)]
    pub round_timeout_s: f64,
    /// Explicit reward weight per rank, best first (one per quorum rank, at least one
    /// positive, each in -1000..=1000); empty (the default) derives them from
    /// `penalised_ranks`. The authors' contract comments [5, 4, 3, 2, 1, -1, -2].
    #[serde(default)]
    pub reward_weights: Vec<i64>,
    /// Which machine executes the contract: "native" (the Rust reducer) or "evm" (the Solidity
    /// contract of `contracts/`, its committed bytecode run in revm; same events and results).
    #[serde(default)]
    pub engine: ContractEngine,
    /// Median of an even count of distances: "lower" middle (swarmfl) or "mean" of the two
    /// middles, floored (authors).
    #[serde(default)]
    pub median: MedianRule,
    /// FedAvg rounding: "nearest", ties away from zero (swarmfl), or "truncate" toward zero
    /// (authors).
    #[serde(default)]
    pub fedavg_rounding: FedAvgRounding,
    /// Refuse (malformed) an accepted model when some `w_i * n`, or the round's running sum
    /// with it, leaves int48: the authors' int48 accumulator reverts such a submission.
    #[serde(default)]
    pub int48_products: bool,
    /// Outlier threshold: "inclusive", `d <= t * N` (swarmfl), or "strict", `d < t * N`
    /// (authors).
    #[serde(default)]
    pub threshold: ThresholdRule,
    /// Ranking key: exact L1 "distance" (swarmfl) or truncated "mae" `floor(d / N)` (authors).
    #[serde(default)]
    pub rank_key: RankKey,
    /// Ranking ties: "stable" submission order (swarmfl) or the authors' "quicksort".
    #[serde(default)]
    pub rank_ties: RankTies,
    /// Payout shares: "exact" to one unit (swarmfl) or "ratio_1e9", normalised to 1e9 and
    /// floored (authors).
    #[serde(default)]
    pub payout_rounding: PayoutRounding,
    /// Pool of an aggregation: "carry" (all the contract holds, remainders included; swarmfl)
    /// or "round" (the round's stakes only; authors).
    #[serde(default)]
    pub pool: PoolRule,
    /// A defence of the reward rule against robots that are paid without collecting data or
    /// training (issue 16, beyond the paper): "none" (the rule's own rewards), "agreement" or
    /// "innovation" (rewards follow a model's agreement with the round's other models; see
    /// `contract::defences`). Needs a staking rule (security on); "none" in every preset but
    /// `e5-smart-defence`.
    #[serde(default)]
    pub defence: Defence,
    /// Percent (0..=100) of an aggregation's pool that a defence refunds in equal parts to the
    /// used submissions; the rest is shared by score.
    #[serde(default = "default_defence_refund_percent")]
    pub defence_refund_percent: u32,
}

fn default_defence_refund_percent() -> u32 {
    50
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
    /// Behaviour of the Byzantine robots.
    pub kind: ByzantineKind,
    /// How many robots are Byzantine (they replace honest ones: the swarm size stays).
    pub count: u32,
    /// Formula variant: the paper's or the reference implementation's.
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
    /// orthogonal to `kind` (beyond the paper; `honest` by default).
    #[serde(default)]
    pub ledger: LedgerBehaviour,
    /// `smart-then-collude`: the share of the robots' tokens (balances on the robot's own
    /// chain, Byzantine over all) above which the Byzantine robots stop acting `smart` and
    /// all submit one harmful model; 0.5 = "more tokens than the honest robots together".
    #[serde(default = "default_switch_token_share")]
    pub switch_token_share: f64,
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

/// The behaviour of Byzantine robots (docs/SPEC.md section 5, and the attacks of `byzantine/`,
/// each documented in its own file).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ByzantineKind {
    /// No Byzantine robots (the count must be 0).
    None,
    /// Uniformly random weights.
    Faulty,
    /// Resubmits the current shared model.
    Malicious,
    /// Follows the trend of the shared model to be ranked first.
    Smart,
    /// Reverses the last aggregation step.
    SignFlip,
    /// Gaussian noise on the shared model.
    Gaussian,
    /// A little is enough: the honest mean moved by a few honest standard deviations.
    Alie,
    /// Inner-product manipulation: the negated honest mean step.
    Ipm,
    /// Min-max: as far from the honest mean as the honest models are from each other.
    MinMax,
    /// Copies an honest model of the round (over-represents one robot's data).
    Mimic,
    /// A model just inside the outlier threshold, against the honest direction, with a huge
    /// claimed sample count.
    InflateSamples,
    /// Trains honestly on corrupted trajectories.
    PoisonData,
    /// The Byzantine robots agree on one model.
    Collude,
    /// `smart` until the Byzantine robots hold a token share, then `collude`.
    SmartThenCollude,
}

impl ByzantineKind {
    /// Every kind, `none` first.
    pub const ALL: [ByzantineKind; 14] = [
        ByzantineKind::None,
        ByzantineKind::Faulty,
        ByzantineKind::Malicious,
        ByzantineKind::Smart,
        ByzantineKind::SignFlip,
        ByzantineKind::Gaussian,
        ByzantineKind::Alie,
        ByzantineKind::Ipm,
        ByzantineKind::MinMax,
        ByzantineKind::Mimic,
        ByzantineKind::InflateSamples,
        ByzantineKind::PoisonData,
        ByzantineKind::Collude,
        ByzantineKind::SmartThenCollude,
    ];

    /// The kind's name as written in configurations.
    pub fn name(self) -> &'static str {
        match self {
            ByzantineKind::None => "none",
            ByzantineKind::Faulty => "faulty",
            ByzantineKind::Malicious => "malicious",
            ByzantineKind::Smart => "smart",
            ByzantineKind::SignFlip => "sign-flip",
            ByzantineKind::Gaussian => "gaussian",
            ByzantineKind::Alie => "alie",
            ByzantineKind::Ipm => "ipm",
            ByzantineKind::MinMax => "min-max",
            ByzantineKind::Mimic => "mimic",
            ByzantineKind::InflateSamples => "inflate-samples",
            ByzantineKind::PoisonData => "poison-data",
            ByzantineKind::Collude => "collude",
            ByzantineKind::SmartThenCollude => "smart-then-collude",
        }
    }
}

/// Which formula a Byzantine behaviour follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ByzantineVariant {
    /// The paper's formulas.
    Paper,
    /// The reference implementation's variants (smart: positive-only noise, w(t) before the
    /// first change).
    Reference,
}

/// Log and metrics settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputConfig {
    /// A full-state snapshot is written to the log every this many checkpoints (0 = never).
    pub snapshot_every_blocks: u32,
}

/// The named configurations shipped with swarmfl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// The paper's values (the default), with the learning rate its code ran (0.01).
    Paper,
    /// The paper's text taken literally: as `Paper` but with its stated learning rate 0.001.
    PaperText,
    /// The reference implementation's values where they differ from the paper.
    Reference,
    /// 15 robots for 600 s: quick, for fixtures and CI.
    Smoke,
    /// Experiment 1: no security, no Byzantine robots; sweep `data.expiration_s`.
    E1Expiration,
    /// Experiment 1: no security, one faulty robot.
    E1Faulty,
    /// Experiment 2: security on, faulty robots; sweep `byzantine.count` 0..7.
    E2Faulty,
    /// Experiment 2: security on, malicious robots; sweep `byzantine.count` 0..7.
    E2Malicious,
    /// Experiment 3: security on, smart robots; sweep `byzantine.count` 0..7.
    E3Smart,
    /// Experiment 4: aggregation rules against attacks, 2000 s at learning rate 0.01; sweep
    /// `contract.rule` x `byzantine.kind` x `byzantine.count`.
    E4Robustness,
    /// Issue 16: smart robots against a defence of the reward rule (`contract.defence`).
    E5SmartDefence,
    /// Baselines: the chain (security on) against Flow-FL gossip and a central server; sweep
    /// `learn.aggregation` and the Byzantine robots.
    E0Baselines,
}

impl Preset {
    /// Every preset, in the order `swarmfl presets` lists them.
    pub const ALL: [Preset; 12] = [
        Preset::Paper,
        Preset::PaperText,
        Preset::Reference,
        Preset::Smoke,
        Preset::E1Expiration,
        Preset::E1Faulty,
        Preset::E2Faulty,
        Preset::E2Malicious,
        Preset::E3Smart,
        Preset::E4Robustness,
        Preset::E5SmartDefence,
        Preset::E0Baselines,
    ];

    /// The preset's name as written on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Paper => "paper",
            Preset::PaperText => "paper-text",
            Preset::Reference => "reference",
            Preset::Smoke => "smoke",
            Preset::E1Expiration => "e1-expiration",
            Preset::E1Faulty => "e1-faulty",
            Preset::E2Faulty => "e2-faulty",
            Preset::E2Malicious => "e2-malicious",
            Preset::E3Smart => "e3-smart",
            Preset::E4Robustness => "e4-robustness",
            Preset::E5SmartDefence => "e5-smart-defence",
            Preset::E0Baselines => "e0-baselines",
        }
    }

    /// One line on what the preset is for.
    pub fn description(self) -> &'static str {
        match self {
            Preset::Paper => {
                "the paper's system: 15 robots, 5 x 5 m, 2.5 m range, 5000 s, security on, SGD 0.01"
            }
            Preset::PaperText => {
                "the paper's text: as `paper` but SGD 0.001 (its figures were made at 0.01)"
            }
            Preset::Reference => {
                "the reference implementation's values: 4 x 4 m, 2.0 m range, 4980 s, SGD 0.01"
            }
            Preset::Smoke => "15 robots for 600 s: quick, for fixtures and CI",
            Preset::E1Expiration => {
                "Exp. 1: security off, no Byzantine robots; sweep data.expiration_s 250..1250"
            }
            Preset::E1Faulty => "Exp. 1: security off, 1 faulty robot, expiration 750 s",
            Preset::E2Faulty => "Exp. 2: security on, faulty robots; sweep byzantine.count 0..7",
            Preset::E2Malicious => {
                "Exp. 2: security on, malicious robots; sweep byzantine.count 0..7"
            }
            Preset::E3Smart => "Exp. 3: security on, smart robots; sweep byzantine.count 0..7",
            Preset::E4Robustness => {
                "Exp. 4: rules x attacks x Byzantine count, 2000 s, learning rate 0.01"
            }
            Preset::E5SmartDefence => {
                "Exp. 5: smart robots against the agreement defence; sweep byzantine.count 0..7"
            }
            Preset::E0Baselines => {
                "Baselines: chain vs Flow-FL gossip vs central server, SGD 0.01; sweep \
                 learn.aggregation x {0, 1 faulty, 3 malicious}"
            }
        }
    }

    /// Looks a preset up by name.
    pub fn from_name(name: &str) -> Result<Preset, ConfigError> {
        Preset::ALL
            .iter()
            .copied()
            .find(|p| p.name() == name)
            .ok_or_else(|| ConfigError::UnknownPreset {
                name: name.to_string(),
                allowed: Preset::ALL
                    .iter()
                    .map(|p| p.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// The preset's full configuration.
    pub fn config(self) -> Config {
        let mut c = Config::paper();
        c.preset = self.name().to_string();
        match self {
            Preset::Paper => {}
            Preset::PaperText => {
                // The rate the paper's text gives (taken from Flow-FL); its code never set one,
                // so Keras' default 0.01 made the figures (docs/SPEC.md, "Learning rate").
                c.learn.learning_rate = 0.001;
            }
            Preset::Reference => {
                c.run.duration_s = 4980.0;
                c.world.arena_side_m = 4.0;
                c.world.obstacle_spread_half_m = 1.5;
                c.world.rab_range_m = 2.0;
            }
            Preset::Smoke => {
                c.run.duration_s = 600.0;
            }
            Preset::E1Expiration => {
                c.contract.security = false;
            }
            Preset::E1Faulty => {
                c.contract.security = false;
                c.byzantine.kind = ByzantineKind::Faulty;
                c.byzantine.count = 1;
            }
            Preset::E2Faulty => {
                c.byzantine.kind = ByzantineKind::Faulty;
                c.byzantine.count = 1;
            }
            Preset::E2Malicious => {
                c.byzantine.kind = ByzantineKind::Malicious;
                c.byzantine.count = 1;
            }
            Preset::E3Smart => {
                c.byzantine.kind = ByzantineKind::Smart;
                c.byzantine.count = 1;
            }
            Preset::E4Robustness => {
                // Short runs by default (the sweep has 225 points); --set run.duration_s=5000
                // for the paper's length.
                c.run.duration_s = 2000.0;
            }
            Preset::E5SmartDefence => {
                // e3-smart with the defence that measured best (RESEARCH.md, e5-smart-defence).
                c.byzantine.kind = ByzantineKind::Smart;
                c.byzantine.count = 1;
                c.contract.defence = Defence::Agreement;
            }
            Preset::E0Baselines => {
                // The paper's system (security on, learning rate 0.01, docs/SPEC.md section
                // 2) at its full 5000 s; the sweep varies learn.aggregation and the Byzantine
                // robots.
            }
        }
        c
    }
}

impl Default for Config {
    fn default() -> Self {
        Preset::Paper.config()
    }
}

impl Config {
    fn paper() -> Config {
        Config {
            preset: "paper".to_string(),
            run: RunConfig {
                duration_s: 5000.0,
                tick_s: 0.1,
            },
            world: WorldConfig {
                robots: 15,
                arena_side_m: 5.0,
                cylinders: 5,
                cylinder_radius_m: 0.15,
                boxes: 5,
                box_side_m: 0.3,
                obstacle_spread_half_m: 0.0,
                robot_radius_m: 0.035,
                wheel_base_m: 0.053,
                cruise_speed_mps: 0.025,
                proximity_sensors: 8,
                proximity_range_m: 0.1,
                proximity_threshold: 0.2,
                random_turn_rate_per_s: 0.1,
                random_turn_max_s: 3.0,
                rab_range_m: 2.5,
                rab_noise_std_m: 0.01,
                rab_occlusion: true,
                rab_packet_drop: 0.0,
                peer_refresh_s: 0.5,
            },
            data: DataConfig {
                trajectory_ticks: 100,
                input_waypoints: 32,
                target_waypoints: 48,
                expiration_s: 750.0,
                heldout_samples: 200,
            },
            learn: LearnConfig {
                lstm_units: 16,
                dropout: 0.2,
                // Keras' default for `optimizer='SGD'`, what the authors' code ran (the text says
                // 0.001; the `paper-text` preset keeps that value).
                learning_rate: 0.01,
                batch_size: 20,
                epochs: 20,
                train_fraction: 0.8,
                training_period_s: 100.0,
                training_duration_s: 0.0,
                min_train_samples: 1,
                aggregation: Aggregation::Chain,
                gossip_outlier_filter: false,
            },
            ledger: LedgerConfig {
                block_period_s: 10.0,
                wiggle_unit_s: 0.5,
                bandwidth_bytes_per_s: 0,
                packet_loss: 0.0,
            },
            contract: ContractConfig {
                security: true,
                initial_tokens: 21,
                stake_tokens: 5,
                token_units: 1_000_000_000,
                weight_scale: 1_000_000_000,
                quorum_fraction: 0.5,
                outlier_threshold: 0.05,
                penalised_ranks: 2,
                rule: Rule::Paper,
                assumed_f: 1,
                round_timeout_s: 0.0,
                reward_weights: Vec::new(),
                engine: ContractEngine::Native,
                median: MedianRule::Lower,
                fedavg_rounding: FedAvgRounding::Nearest,
                int48_products: false,
                threshold: ThresholdRule::Inclusive,
                rank_key: RankKey::Distance,
                rank_ties: RankTies::Stable,
                payout_rounding: PayoutRounding::Exact,
                pool: PoolRule::Carry,
                defence: Defence::None,
                defence_refund_percent: 50,
            },
            byzantine: ByzantineConfig {
                kind: ByzantineKind::None,
                count: 0,
                variant: ByzantineVariant::Paper,
                claimed_samples: 200,
                faulty_range: 0.5,
                wait_for_honest: 2,
                scale: 1.0,
                sigma: 0.1,
                alie_z: 1.0,
                threshold_fraction: 0.99,
                inflated_samples: u32::MAX,
                ledger: LedgerBehaviour::Honest,
                switch_token_share: 0.5,
            },
            faults: FaultsConfig::default(),
            output: OutputConfig {
                snapshot_every_blocks: 50,
            },
        }
    }

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

    /// The quorum: max(floor(q * N_r), 1).
    pub fn quorum(&self) -> u32 {
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

    /// The full TOML text of this configuration.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a Config always serialises to TOML")
    }

    /// The blake3 hash of the canonical TOML text: names a configuration in results.
    pub fn hash(&self) -> blake3::Hash {
        blake3::hash(self.to_toml().as_bytes())
    }

    /// Resolves a configuration: the preset, then the file (a partial TOML overlaid on the
    /// preset; it may name its own `preset`), then each `key.path=value` override in order,
    /// then validation.
    pub fn resolve(
        preset: Option<&str>,
        file: Option<&Path>,
        overrides: &[String],
    ) -> Result<Config, ConfigError> {
        let text = match file {
            Some(path) => Some(std::fs::read_to_string(path).map_err(|e| ConfigError::Io {
                path: path.display().to_string(),
                message: e.to_string(),
            })?),
            None => None,
        };
        let source_name = file.map(|p| p.display().to_string()).unwrap_or_default();
        Config::resolve_text(
            preset,
            text.as_deref().map(|t| (t, source_name.as_str())),
            overrides,
        )
    }

    /// Parses the text of a configuration file (a partial TOML overlaid on its own `preset`, or
    /// on `paper`) and validates it; `source_name` names the text in errors. This is
    /// [`Config::resolve`] without the file system and without overrides.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Config, ConfigError> {
        Config::resolve_text(None, Some((text, source_name)), &[])
    }

    /// [`Config::resolve`] on a file's text and name instead of its path.
    fn resolve_text(
        preset: Option<&str>,
        file: Option<(&str, &str)>,
        overrides: &[String],
    ) -> Result<Config, ConfigError> {
        let mut file_table: Option<(toml::Table, &str)> = None;
        let mut preset_name = preset.map(str::to_string);
        if let Some((text, source_name)) = file {
            let table: toml::Table = toml::from_str(text).map_err(|e| ConfigError::Parse {
                source_name: source_name.to_string(),
                message: e.to_string(),
            })?;
            if preset_name.is_none() {
                if let Some(p) = table.get("preset").and_then(|v| v.as_str()) {
                    preset_name = Some(p.to_string());
                }
            }
            file_table = Some((table, source_name));
        }
        let preset = Preset::from_name(preset_name.as_deref().unwrap_or("paper"))?;
        let mut config = preset.config();
        let mut explicit = std::collections::BTreeSet::new();
        if let Some((table, _)) = &file_table {
            collect_keys("", table, &mut explicit);
        }
        if let Some((table, source_name)) = file_table {
            let mut base = toml::Value::try_from(&config).expect("Config serialises");
            merge(&mut base, toml::Value::Table(table), "", source_name)?;
            config = base
                .try_into()
                .map_err(|e: toml::de::Error| ConfigError::Parse {
                    source_name: source_name.to_string(),
                    message: e.to_string(),
                })?;
            config.preset = preset.name().to_string();
        }
        for assignment in overrides {
            config.set(assignment)?;
            if let Some((key, _)) = assignment.split_once('=') {
                explicit.insert(key.trim().to_string());
            }
        }
        config.derive(&explicit);
        config.validate().map_err(|e| match e {
            ConfigError::OutOfRange { ref key, .. }
                if !explicit.is_empty() && !explicit.contains(key) =>
            {
                ConfigError::NotSetByYou {
                    key: key.clone(),
                    preset: config.preset.clone(),
                    set: explicit.iter().cloned().collect::<Vec<_>>().join(", "),
                    source: Box::new(e),
                }
            }
            e => e,
        })?;
        Ok(config)
    }

    /// Makes the values the user did not set follow the ones they did, where a preset's value
    /// only suits the preset's swarm: `contract.penalised_ranks` is clamped to `quorum - 1` (a
    /// swarm of 2..5 robots has a quorum of 1 or 2, so the paper's 2 of 7 cannot apply) and
    /// `world.peer_refresh_s` is raised to `run.tick_s` (peers are refreshed at most once a
    /// tick). `explicit` holds the dotted keys set by a file or an override: those are never
    /// changed, so a contradiction among them is reported by [`Config::validate`] naming the
    /// user's own key. A configuration that already validates is left as it is, so every
    /// existing run keeps its records.
    pub fn derive(&mut self, explicit: &std::collections::BTreeSet<String>) {
        let set = |key: &str| explicit.contains(key);
        if !set("contract.penalised_ranks") {
            let max = self.quorum().saturating_sub(1);
            self.contract.penalised_ranks = self.contract.penalised_ranks.min(max);
        }
        if !set("world.peer_refresh_s") && self.world.peer_refresh_s < self.run.tick_s {
            self.world.peer_refresh_s = self.run.tick_s;
        }
    }

    /// Applies one `key.path=value` override. The value is TOML (`0.5`, `true`, `"faulty"`,
    /// `[1, 1, -1]`); a bare word is taken as a string. The key must exist and the value must
    /// have the field's type.
    pub fn set(&mut self, assignment: &str) -> Result<(), ConfigError> {
        let (key, raw) = assignment
            .split_once('=')
            .ok_or_else(|| ConfigError::Override {
                assignment: assignment.to_string(),
                message: "expected key.path=value, e.g. --set world.robots=30".to_string(),
            })?;
        let key = key.trim();
        let raw = raw.trim();
        let value: toml::Value = match toml::from_str::<toml::Table>(&format!("v = {raw}")) {
            Ok(mut t) => t.remove("v").expect("parsed table has v"),
            Err(_) => toml::Value::String(raw.to_string()),
        };
        let mut root = toml::Value::try_from(&*self).expect("Config serialises");
        let mut slot = &mut root;
        let mut walked = String::new();
        for part in key.split('.') {
            let table = slot.as_table_mut().ok_or_else(|| ConfigError::UnknownKey {
                key: key.to_string(),
                allowed: format!("`{walked}` is a value, not a table; set `{walked}` itself"),
            })?;
            if !table.contains_key(part) {
                let mut allowed: Vec<&str> = table.keys().map(String::as_str).collect();
                allowed.sort_unstable();
                return Err(ConfigError::UnknownKey {
                    key: key.to_string(),
                    allowed: format!(
                        "{}: {}",
                        if walked.is_empty() {
                            "top-level keys"
                        } else {
                            walked.as_str()
                        },
                        allowed.join(", ")
                    ),
                });
            }
            if !walked.is_empty() {
                walked.push('.');
            }
            walked.push_str(part);
            slot = table.get_mut(part).expect("checked above");
        }
        let value = coerce(slot, value).map_err(|expected| ConfigError::WrongType {
            key: key.to_string(),
            value: raw.to_string(),
            expected,
        })?;
        *slot = value;
        let updated: Config =
            root.try_into()
                .map_err(|e: toml::de::Error| ConfigError::WrongType {
                    key: key.to_string(),
                    value: raw.to_string(),
                    expected: e.message().to_string(),
                })?;
        *self = updated;
        Ok(())
    }

    /// Checks every value against its allowed range; the first violation is returned, naming
    /// the key, the value and what is allowed.
    pub fn validate(&self) -> Result<(), ConfigError> {
        fn range(key: &str, value: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
            if value.is_finite() && value >= lo && value <= hi {
                Ok(())
            } else {
                Err(ConfigError::OutOfRange {
                    key: key.to_string(),
                    value: value.to_string(),
                    allowed: format!("a number in [{lo}, {hi}]"),
                })
            }
        }
        fn positive(key: &str, value: f64) -> Result<(), ConfigError> {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(ConfigError::OutOfRange {
                    key: key.to_string(),
                    value: value.to_string(),
                    allowed: "a finite number > 0".to_string(),
                })
            }
        }
        fn int(key: &str, value: u64, lo: u64, hi: u64) -> Result<(), ConfigError> {
            if value >= lo && value <= hi {
                Ok(())
            } else {
                Err(ConfigError::OutOfRange {
                    key: key.to_string(),
                    value: value.to_string(),
                    allowed: format!("an integer in [{lo}, {hi}]"),
                })
            }
        }
        let c = self;
        // The preset names output folders (`runs/<preset>-seed<seed>`), so it must be one of
        // the known names, never a path.
        if Preset::from_name(&c.preset).is_err() {
            return Err(ConfigError::OutOfRange {
                key: "preset".to_string(),
                value: format!("{:?}", c.preset),
                allowed: format!("one of {}", Preset::ALL.map(Preset::name).join(", ")),
            });
        }
        positive("run.duration_s", c.run.duration_s)?;
        range("run.duration_s", c.run.duration_s, 0.0, 1.0e7)?;
        range("run.tick_s", c.run.tick_s, 0.001, 10.0)?;
        int("world.robots", c.world.robots.into(), 1, 10_000)?;
        range("world.arena_side_m", c.world.arena_side_m, 0.1, 10_000.0)?;
        int("world.cylinders", c.world.cylinders.into(), 0, 100_000)?;
        range(
            "world.cylinder_radius_m",
            c.world.cylinder_radius_m,
            0.001,
            1000.0,
        )?;
        int("world.boxes", c.world.boxes.into(), 0, 100_000)?;
        range("world.box_side_m", c.world.box_side_m, 0.001, 1000.0)?;
        range(
            "world.obstacle_spread_half_m",
            c.world.obstacle_spread_half_m,
            0.0,
            5_000.0,
        )?;
        range("world.robot_radius_m", c.world.robot_radius_m, 0.001, 10.0)?;
        range("world.wheel_base_m", c.world.wheel_base_m, 0.001, 20.0)?;
        range(
            "world.cruise_speed_mps",
            c.world.cruise_speed_mps,
            0.0,
            10.0,
        )?;
        int(
            "world.proximity_sensors",
            c.world.proximity_sensors.into(),
            1,
            64,
        )?;
        range(
            "world.proximity_range_m",
            c.world.proximity_range_m,
            0.001,
            10.0,
        )?;
        range(
            "world.proximity_threshold",
            c.world.proximity_threshold,
            0.0,
            1.0,
        )?;
        range(
            "world.random_turn_rate_per_s",
            c.world.random_turn_rate_per_s,
            0.0,
            100.0,
        )?;
        range(
            "world.random_turn_max_s",
            c.world.random_turn_max_s,
            0.0,
            1000.0,
        )?;
        range("world.rab_range_m", c.world.rab_range_m, 0.0, 10_000.0)?;
        range("world.rab_noise_std_m", c.world.rab_noise_std_m, 0.0, 100.0)?;
        range("world.rab_packet_drop", c.world.rab_packet_drop, 0.0, 1.0)?;
        range(
            "world.peer_refresh_s",
            c.world.peer_refresh_s,
            c.run.tick_s,
            1.0e6,
        )?;
        int(
            "data.trajectory_ticks",
            c.data.trajectory_ticks.into(),
            2,
            100_000,
        )?;
        int(
            "data.input_waypoints",
            c.data.input_waypoints.into(),
            1,
            10_000,
        )?;
        int(
            "data.target_waypoints",
            c.data.target_waypoints.into(),
            1,
            10_000,
        )?;
        if c.data.input_waypoints + c.data.target_waypoints > c.data.trajectory_ticks {
            return Err(ConfigError::OutOfRange {
                key: "data.target_waypoints".to_string(),
                value: c.data.target_waypoints.to_string(),
                allowed: format!(
                    "input_waypoints + target_waypoints <= trajectory_ticks ({})",
                    c.data.trajectory_ticks
                ),
            });
        }
        range("data.expiration_s", c.data.expiration_s, 0.0, 1.0e7)?;
        int(
            "data.heldout_samples",
            c.data.heldout_samples.into(),
            0,
            1_000_000,
        )?;
        int("learn.lstm_units", c.learn.lstm_units.into(), 1, 1024)?;
        range("learn.dropout", c.learn.dropout, 0.0, 0.99)?;
        range("learn.learning_rate", c.learn.learning_rate, 0.0, 10.0)?;
        int("learn.batch_size", c.learn.batch_size.into(), 1, 100_000)?;
        int("learn.epochs", c.learn.epochs.into(), 0, 100_000)?;
        range("learn.train_fraction", c.learn.train_fraction, 0.01, 1.0)?;
        positive("learn.training_period_s", c.learn.training_period_s)?;
        range(
            "learn.training_duration_s",
            c.learn.training_duration_s,
            0.0,
            1.0e6,
        )?;
        positive("ledger.block_period_s", c.ledger.block_period_s)?;
        range("ledger.wiggle_unit_s", c.ledger.wiggle_unit_s, 0.0, 1.0e6)?;
        range("ledger.packet_loss", c.ledger.packet_loss, 0.0, 1.0)?;
        int(
            "contract.stake_tokens",
            c.contract.stake_tokens,
            0,
            c.contract.initial_tokens.max(1) * 1000,
        )?;
        int(
            "contract.token_units",
            c.contract.token_units,
            1,
            1_000_000_000_000,
        )?;
        int(
            "contract.weight_scale",
            c.contract.weight_scale,
            1,
            1_000_000_000_000,
        )?;
        let total = u128::from(c.world.robots)
            * u128::from(c.contract.initial_tokens)
            * u128::from(c.contract.token_units);
        if total > u128::from(u64::MAX / 4) {
            return Err(ConfigError::OutOfRange {
                key: "contract.initial_tokens".to_string(),
                value: c.contract.initial_tokens.to_string(),
                allowed: "robots * initial_tokens * token_units must fit in 2^62 units".to_string(),
            });
        }
        range(
            "contract.quorum_fraction",
            c.contract.quorum_fraction,
            0.0,
            1.0,
        )?;
        range(
            "contract.outlier_threshold",
            c.contract.outlier_threshold,
            0.0,
            1.0e6,
        )?;
        int(
            "contract.penalised_ranks",
            c.contract.penalised_ranks.into(),
            0,
            u64::from(c.quorum() - 1),
        )?;
        if !c.contract.security && !matches!(c.contract.rule, Rule::Paper | Rule::Fedavg) {
            return Err(ConfigError::OutOfRange {
                key: "contract.rule".to_string(),
                value: c.contract.rule.name().to_string(),
                allowed: "fedavg or paper while contract.security = false (security off is \
                          the fedavg rule); set contract.security = true to use another rule"
                    .to_string(),
            });
        }
        let rule = c.rule();
        let max_f = (0..=c.quorum())
            .take_while(|&f| rule.min_quorum(f) <= c.quorum())
            .last();
        match max_f {
            Some(max_f) => int(
                "contract.assumed_f",
                c.contract.assumed_f.into(),
                0,
                max_f.into(),
            )
            .map_err(|e| match e {
                ConfigError::OutOfRange {
                    key,
                    value,
                    allowed,
                } => ConfigError::OutOfRange {
                    key,
                    value,
                    allowed: format!(
                        "{allowed} for rule {} with quorum {} (it needs quorum >= {} with f = {})",
                        rule.name(),
                        c.quorum(),
                        rule.min_quorum(c.contract.assumed_f),
                        c.contract.assumed_f
                    ),
                },
                e => e,
            })?,
            None => {
                return Err(ConfigError::OutOfRange {
                    key: "contract.rule".to_string(),
                    value: rule.name().to_string(),
                    allowed: format!(
                        "a rule defined for quorum {} (it needs quorum >= {} even with f = 0); \
                         raise contract.quorum_fraction",
                        c.quorum(),
                        rule.min_quorum(0)
                    ),
                })
            }
        }
        let k = &c.contract.reward_weights;
        if !k.is_empty()
            && (k.len() != c.quorum() as usize
                || !k.iter().any(|&w| w > 0)
                || k.iter().any(|w| w.abs() > 1000))
        {
            return Err(ConfigError::OutOfRange {
                key: "contract.reward_weights".to_string(),
                value: format!("{k:?}"),
                allowed: format!(
                    "empty (derived from penalised_ranks) or one weight per rank of the quorum \
                     ({}), at least one positive, each in -1000..=1000",
                    c.quorum()
                ),
            });
        }
        crate::contract::options::check_rule_options(c)?;
        int(
            "byzantine.count",
            c.byzantine.count.into(),
            0,
            c.world.robots.into(),
        )?;
        let misbehaves = c.byzantine.kind != ByzantineKind::None
            || c.byzantine.ledger != LedgerBehaviour::Honest;
        if misbehaves != (c.byzantine.count > 0) {
            return Err(ConfigError::OutOfRange {
                key: "byzantine.count".to_string(),
                value: c.byzantine.count.to_string(),
                allowed: format!(
                    "0 when byzantine.kind = \"none\" and byzantine.ledger = \"honest\", at \
                     least 1 otherwise (kind is {:?}, ledger is {:?}); set both, e.g. \
                     --set byzantine.kind=faulty --set byzantine.count=3",
                    c.byzantine.kind, c.byzantine.ledger
                ),
            });
        }
        range(
            "contract.round_timeout_s",
            c.contract.round_timeout_s,
            0.0,
            1.0e9,
        )?;
        if let Err((key, value, allowed)) = c.faults.check(c.world.robots, c.run.duration_s) {
            return Err(ConfigError::OutOfRange {
                key,
                value,
                allowed,
            });
        }
        crate::aggregation::supports(c)?;
        // After the aggregation: a baseline refuses the engine naming learn.aggregation, in
        // builds with or without the evm feature.
        if c.contract.engine == ContractEngine::Evm {
            crate::contract::evm::supports(c)?;
        }
        int(
            "byzantine.claimed_samples",
            c.byzantine.claimed_samples.into(),
            1,
            1_000_000_000,
        )?;
        range(
            "byzantine.faulty_range",
            c.byzantine.faulty_range,
            0.0,
            1000.0,
        )?;
        int(
            "byzantine.wait_for_honest",
            c.byzantine.wait_for_honest.into(),
            1,
            10_000,
        )?;
        range("byzantine.scale", c.byzantine.scale, 0.0, 1.0e6)?;
        range("byzantine.sigma", c.byzantine.sigma, 0.0, 1000.0)?;
        range("byzantine.alie_z", c.byzantine.alie_z, -1000.0, 1000.0)?;
        range(
            "byzantine.threshold_fraction",
            c.byzantine.threshold_fraction,
            0.0,
            1000.0,
        )?;
        int(
            "byzantine.inflated_samples",
            c.byzantine.inflated_samples.into(),
            1,
            u32::MAX.into(),
        )?;
        if !(c.byzantine.switch_token_share > 0.0 && c.byzantine.switch_token_share < 1.0) {
            return Err(ConfigError::OutOfRange {
                key: "byzantine.switch_token_share".to_string(),
                value: c.byzantine.switch_token_share.to_string(),
                allowed: "a share strictly between 0 and 1 (0.5: more tokens than the honest \
                          robots together)"
                    .to_string(),
            });
        }
        int(
            "contract.defence_refund_percent",
            c.contract.defence_refund_percent.into(),
            0,
            100,
        )?;
        if c.contract.defence != Defence::None && !c.rule().stakes() {
            return Err(ConfigError::OutOfRange {
                key: "contract.defence".to_string(),
                value: c.contract.defence.name().to_string(),
                allowed: "\"none\" with contract.security = false or contract.rule = fedavg \
                          (no stakes, no rewards to defend); set contract.security = true and a \
                          staking rule, or contract.defence = none"
                    .to_string(),
            });
        }
        Ok(())
    }

    /// Every leaf of the configuration as `dotted.key -> value as TOML text`, sorted by key.
    pub fn flat_values(&self) -> BTreeMap<String, String> {
        fn flatten(prefix: &str, value: &toml::Value, out: &mut BTreeMap<String, String>) {
            match value {
                toml::Value::Table(t) => {
                    for (k, v) in t {
                        let key = if prefix.is_empty() {
                            k.clone()
                        } else {
                            format!("{prefix}.{k}")
                        };
                        flatten(&key, v, out);
                    }
                }
                v => {
                    out.insert(prefix.to_string(), v.to_string());
                }
            }
        }
        let mut out = BTreeMap::new();
        flatten(
            "",
            &toml::Value::try_from(self).expect("Config serialises"),
            &mut out,
        );
        out
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

    /// Checks that `next` differs from `self` only in keys that may change in the middle of a
    /// run ([`RECONFIGURABLE`]), and returns the changed keys.
    pub fn check_reconfiguration(&self, next: &Config) -> Result<Vec<String>, ConfigError> {
        let changed = self.changed_keys(next);
        if let Some(key) = changed.iter().find(|k| !is_reconfigurable(k)) {
            return Err(ConfigError::NotReconfigurable {
                key: key.clone(),
                allowed: RECONFIGURABLE.join(", "),
            });
        }
        Ok(changed)
    }
}

/// The configuration keys a fork may change in the middle of a run (a trailing `.*` stands for
/// every key of that table). Everything else shapes the world, the model or the ledger from
/// genesis on: change it with a new run instead.
///
/// - `run.duration_s`: the run ends at the new time (after the fork point).
/// - `learn.*` except `lstm_units`: the robots' next trainings use the new hyper-parameters.
/// - `contract.security`, `stake_tokens`, `quorum_fraction`, `outlier_threshold`,
///   `penalised_ranks`, `rule`, `assumed_f`, `reward_weights` and the variant options
///   (`median` .. `pool`): the contract's rules change for the blocks sealed after the fork
///   point
///   (activation by block timestamp, as Ethereum's time-based upgrades); the round open on a
///   chain when it crosses the activation is restarted and its stakes refunded.
/// - `byzantine.*`: which robots misbehave, and how, from the fork point on.
/// - `output.*`: presentation only.
pub const RECONFIGURABLE: &[&str] = &[
    "run.duration_s",
    "learn.dropout",
    "learn.learning_rate",
    "learn.batch_size",
    "learn.epochs",
    "learn.train_fraction",
    "learn.training_period_s",
    "learn.training_duration_s",
    "learn.min_train_samples",
    "contract.security",
    "contract.stake_tokens",
    "contract.quorum_fraction",
    "contract.outlier_threshold",
    "contract.penalised_ranks",
    "contract.rule",
    "contract.assumed_f",
    "contract.reward_weights",
    "contract.median",
    "contract.fedavg_rounding",
    "contract.int48_products",
    "contract.threshold",
    "contract.rank_key",
    "contract.rank_ties",
    "contract.payout_rounding",
    "contract.pool",
    "contract.defence",
    "contract.defence_refund_percent",
    "byzantine.*",
    "output.*",
];

/// True when `key` may change in the middle of a run (see [`RECONFIGURABLE`]).
pub fn is_reconfigurable(key: &str) -> bool {
    RECONFIGURABLE
        .iter()
        .any(|pattern| match pattern.strip_suffix('*') {
            Some(table) => key.starts_with(table),
            None => key == *pattern,
        })
}

/// Overlays `patch` on `base`, table by table; a key that `base` lacks is an error naming it.
fn merge(
    base: &mut toml::Value,
    patch: toml::Value,
    prefix: &str,
    source_name: &str,
) -> Result<(), ConfigError> {
    match (base, patch) {
        (toml::Value::Table(b), toml::Value::Table(p)) => {
            for (k, v) in p {
                let path = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v, &path, source_name)?,
                    None => {
                        let mut allowed: Vec<&str> = b.keys().map(String::as_str).collect();
                        allowed.sort_unstable();
                        return Err(ConfigError::UnknownKey {
                            key: format!("{path} (in {source_name})"),
                            allowed: format!(
                                "{}: {}",
                                if prefix.is_empty() {
                                    "top-level keys"
                                } else {
                                    prefix
                                },
                                allowed.join(", ")
                            ),
                        });
                    }
                }
            }
            Ok(())
        }
        (slot, value) => {
            let shown = value.to_string();
            *slot = coerce(slot, value).map_err(|expected| ConfigError::WrongType {
                key: format!("{prefix} (in {source_name})"),
                value: shown,
                expected,
            })?;
            Ok(())
        }
    }
}

/// Converts `value` to the type of `slot` where that loses nothing (an integer where a float is
/// expected); otherwise says what type was expected.
fn coerce(slot: &toml::Value, value: toml::Value) -> Result<toml::Value, String> {
    use toml::Value as V;
    match (slot, value) {
        (V::Float(_), V::Integer(i)) => Ok(V::Float(i as f64)),
        (V::Float(_), v @ V::Float(_)) => Ok(v),
        (V::Integer(_), v @ V::Integer(_)) => Ok(v),
        (V::Boolean(_), v @ V::Boolean(_)) => Ok(v),
        (V::String(_), v @ V::String(_)) => Ok(v),
        (V::Array(_), v @ V::Array(_)) => Ok(v),
        (V::Table(_), v @ V::Table(_)) => Ok(v),
        (slot, _) => Err(match slot {
            V::Float(_) => "a number".to_string(),
            V::Integer(_) => "an integer".to_string(),
            V::Boolean(_) => "true or false".to_string(),
            V::String(s) => format!("a string (currently {s:?})"),
            V::Array(_) => "an array, e.g. [1, 1, -1]".to_string(),
            V::Table(_) => "a table (name a field inside it)".to_string(),
            V::Datetime(_) => "a datetime".to_string(),
        }),
    }
}

/// What is wrong with a configuration, and how to fix it.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ConfigError {
    /// The preset name is not known.
    #[error("unknown preset {name:?}; the presets are: {allowed} (see `swarmfl presets`)")]
    UnknownPreset {
        /// The name given.
        name: String,
        /// The names allowed.
        allowed: String,
    },
    /// The configuration file could not be read.
    #[error("cannot read configuration file {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The TOML text is not valid or does not match the configuration tree.
    #[error("invalid configuration in {source_name}: {message}")]
    Parse {
        /// Where the text came from.
        source_name: String,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A key that does not exist.
    #[error("unknown configuration key `{key}`; {allowed} (see `swarmfl config`)")]
    UnknownKey {
        /// The key as given.
        key: String,
        /// The keys allowed at that level.
        allowed: String,
    },
    /// A value of the wrong type.
    #[error("configuration key `{key}`: value `{value}` has the wrong type; expected {expected}")]
    WrongType {
        /// The key.
        key: String,
        /// The value as given.
        value: String,
        /// The expected type.
        expected: String,
    },
    /// A value outside its allowed range.
    #[error("configuration key `{key}`: value {value} is out of range; allowed: {allowed}")]
    OutOfRange {
        /// The key.
        key: String,
        /// The value.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// A key that cannot change in the middle of a run (a fork's override).
    #[error("configuration key `{key}` cannot change in the middle of a run (it shapes the world, the model or the ledger from genesis); keys a fork may change: {allowed}")]
    NotReconfigurable {
        /// The key.
        key: String,
        /// The keys that may change.
        allowed: String,
    },
    /// A value the user did not set (it comes from the preset) that conflicts with the values
    /// they did set.
    #[error("{source}; you did not set `{key}` (preset `{preset}` gives it), but it no longer fits what you set ({set}): set `{key}` too, or change those values")]
    NotSetByYou {
        /// The preset's key that is out of range.
        key: String,
        /// The preset it came from.
        preset: String,
        /// The keys the user set, comma-separated.
        set: String,
        /// The range error.
        source: Box<ConfigError>,
    },
    /// A `--set` argument that is not `key=value`.
    #[error("invalid override `{assignment}`: {message}")]
    Override {
        /// The argument.
        assignment: String,
        /// What is wrong.
        message: String,
    },
}

/// Every dotted key of a value in a (partial) TOML table (`world.robots`, not `world`).
fn collect_keys(prefix: &str, table: &toml::Table, out: &mut std::collections::BTreeSet<String>) {
    for (k, v) in table {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(t) => collect_keys(&key, t, out),
            _ => {
                out.insert(key);
            }
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_is_valid_and_round_trips_through_toml() {
        for preset in Preset::ALL {
            let config = preset.config();
            config
                .validate()
                .unwrap_or_else(|e| panic!("{preset}: {e}"));
            let back: Config = toml::from_str(&config.to_toml()).unwrap();
            assert_eq!(back, config, "{preset}");
        }
    }

    /// `contract.rule` is listed in every resolved configuration; a configuration written
    /// before rules existed (no `rule`, no `assumed_f`) reads as `paper`, and
    /// `security = false` still means `fedavg`.
    #[test]
    fn the_rule_is_listed_and_old_configurations_read() {
        let paper = Preset::Paper.config();
        assert!(paper.to_toml().contains("rule = \"paper\""));
        assert_eq!(paper.flat_values()["contract.rule"], "\"paper\"");
        let mut old: toml::Table = toml::from_str(&paper.to_toml()).unwrap();
        let contract = old["contract"].as_table_mut().unwrap();
        contract.remove("rule");
        contract.remove("assumed_f");
        contract.insert("security".into(), toml::Value::Boolean(false));
        let text = toml::to_string(&old).unwrap();
        let c = Config::from_toml_str(&text, "old.toml").unwrap();
        assert_eq!(c.contract.rule, Rule::Paper);
        assert_eq!(c.rule(), Rule::Fedavg);
        let mut krum = Preset::Paper.config();
        krum.set("contract.rule=krum").unwrap();
        krum.validate().unwrap();
        krum.set("contract.assumed_f=3").unwrap();
        let e = krum.validate().unwrap_err().to_string();
        assert!(
            e.contains("contract.assumed_f") && e.contains("krum"),
            "{e}"
        );
    }

    #[test]
    fn paper_quorum_is_seven() {
        assert_eq!(Preset::Paper.config().quorum(), 7);
        assert_eq!(
            Preset::Paper.config().reward_weights(),
            vec![1, 1, 1, 1, 1, -1, -1]
        );
    }

    #[test]
    fn overrides_set_nested_fields_and_coerce_integers_to_floats() {
        let c = Config::resolve(
            Some("smoke"),
            None,
            &[
                "world.rab_range_m=3".into(),
                "byzantine.kind=faulty".into(),
                "byzantine.count=2".into(),
            ],
        )
        .unwrap();
        assert_eq!(c.world.rab_range_m, 3.0);
        assert_eq!(c.byzantine.kind, ByzantineKind::Faulty);
        assert_eq!(c.byzantine.count, 2);
    }

    fn check_err(overrides: &[&str], expect: &str) {
        let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        let err = Config::resolve(None, None, &overrides)
            .unwrap_err()
            .to_string();
        assert!(err.contains(expect), "error {err:?} lacks {expect:?}");
    }

    #[test]
    fn errors_name_the_key_the_value_and_what_is_allowed() {
        check_err(
            &["world.robtos=3"],
            "unknown configuration key `world.robtos`",
        );
        check_err(&["world.robtos=3"], "rab_range_m");
        check_err(
            &["world.robots=many"],
            "`world.robots`: value `many` has the wrong type; expected an integer",
        );
        check_err(
            &["world.robots=0"],
            "`world.robots`: value 0 is out of range; allowed: an integer in [1, 10000]",
        );
        check_err(&["learn.dropout=1.5"], "learn.dropout");
        check_err(&["byzantine.kind=evil"], "byzantine.kind");
        check_err(&["byzantine.kind=faulty"], "byzantine.count");
        check_err(&["noequals"], "expected key.path=value");
        check_err(
            &["world.robots.x=1"],
            "unknown configuration key `world.robots.x`; `world.robots` is a value, not a table",
        );
        check_err(
            &["preset=../../etc"],
            "`preset`: value \"../../etc\" is out of range; allowed: one of paper, paper-text, reference",
        );
        let err = Config::resolve(Some("papr"), None, &[])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("unknown preset \"papr\"") && err.contains("e3-smart"),
            "{err}"
        );
    }

    /// `contract.engine = evm` runs contracts/SwarmFL.sol, the paper's contract with security
    /// on or off: every other rule, and the round deadline it lacks, are refused with the key,
    /// the value and the fix; native runs keep them.
    #[cfg(feature = "evm")]
    #[test]
    fn the_evm_engine_refuses_what_the_solidity_contract_lacks() {
        for rule in crate::contract::rules::ALL_RULES {
            let set = |engine: &str| {
                Config::resolve(
                    None,
                    None,
                    &[
                        format!("contract.rule={}", rule.name()),
                        format!("contract.engine={engine}"),
                    ],
                )
            };
            set("native").unwrap_or_else(|e| panic!("{}: {e}", rule.name()));
            match (rule, set("evm")) {
                (Rule::Paper | Rule::Fedavg, got) => {
                    got.unwrap_or_else(|e| panic!("{}: {e}", rule.name()));
                }
                (_, Ok(_)) => panic!("{} accepted under evm", rule.name()),
                (_, Err(e)) => {
                    let e = e.to_string();
                    assert!(
                        e.contains(&format!("`contract.rule`: value {}", rule.name()))
                            && e.contains("contract.engine = evm")
                            && e.contains("set contract.engine = native"),
                        "{e}"
                    );
                }
            }
        }
        // Security off is the fedavg rule, which the contract implements.
        Config::resolve(
            None,
            None,
            &[
                "contract.engine=evm".into(),
                "contract.security=false".into(),
            ],
        )
        .unwrap();
        check_err(
            &["contract.engine=evm", "contract.round_timeout_s=300"],
            "`contract.round_timeout_s`: value 300 is out of range; allowed: 0 (no deadline) \
             with contract.engine = evm",
        );
        Config::resolve(None, None, &["contract.round_timeout_s=300".into()]).unwrap();
    }

    /// Without the `evm` feature, `contract.engine = evm` is refused with the command that
    /// builds the engine; `native` still runs.
    #[cfg(not(feature = "evm"))]
    #[test]
    fn the_evm_engine_names_the_feature_in_a_build_without_it() {
        check_err(
            &["contract.engine=evm"],
            "`contract.engine`: value evm is out of range; allowed: native in this build of \
             swarmfl, which was built without the EVM engine (cargo feature `evm`, off by \
             default); rebuild with `cargo build --release -p replay-cli --features evm`",
        );
        Config::resolve(None, None, &["contract.engine=native".into()]).unwrap();
    }

    /// The authors' variant options describe the paper's contract: a robust rule would ignore
    /// them, so setting one with it is refused, naming the option.
    #[test]
    fn variant_options_are_refused_with_a_robust_rule() {
        check_err(
            &["contract.rule=median", "contract.median=mean"],
            "`contract.median`: value \"mean\" is out of range; allowed: its default with \
             contract.rule = median",
        );
        check_err(
            &[
                "contract.rule=krum",
                "contract.reward_weights=[5, 4, 3, 2, 1, -1, -2]",
            ],
            "`contract.reward_weights`: value [5, 4, 3, 2, 1, -1, -2]",
        );
        check_err(
            &["contract.rule=krum", "contract.pool=round"],
            "remove `contract.pool`, or set contract.rule = paper",
        );
        for rule in ["paper", "fedavg"] {
            Config::resolve(
                None,
                None,
                &[
                    format!("contract.rule={rule}"),
                    "contract.median=mean".into(),
                    "contract.pool=round".into(),
                    "contract.reward_weights=[5, 4, 3, 2, 1, -1, -2]".into(),
                ],
            )
            .unwrap_or_else(|e| panic!("{rule}: {e}"));
        }
    }

    #[test]
    fn a_file_overlays_the_preset_and_names_itself_in_errors() {
        let dir = std::env::temp_dir().join(format!("swarmfl-config-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.toml");
        std::fs::write(&good, "preset = \"reference\"\n[world]\nrobots = 20\n").unwrap();
        let c = Config::resolve(None, Some(&good), &[]).unwrap();
        assert_eq!(
            (c.world.robots, c.world.rab_range_m, c.preset.as_str()),
            (20, 2.0, "reference")
        );
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, "[world]\nrobots = 20\nspeed = 3\n").unwrap();
        let err = Config::resolve(None, Some(&bad), &[])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("world.speed") && err.contains("bad.toml"),
            "{err}"
        );
        let broken = dir.join("broken.toml");
        std::fs::write(&broken, "[world\nrobots = 20\n").unwrap();
        let err = Config::resolve(None, Some(&broken), &[])
            .unwrap_err()
            .to_string();
        assert!(err.contains("broken.toml") && err.contains("line"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn small_swarms_and_long_ticks_derive_what_the_user_did_not_set() {
        for robots in 1..=5u32 {
            let c = Config::resolve(Some("smoke"), None, &[format!("world.robots={robots}")])
                .unwrap_or_else(|e| panic!("{robots} robots: {e}"));
            assert_eq!(
                c.contract.penalised_ranks,
                c.quorum() - 1,
                "{robots} robots"
            );
            assert!(c.reward_weights()[0] == 1);
        }
        // The paper's swarm keeps the paper's ranks: derivation changes nothing that validates.
        let paper = Config::resolve(None, None, &["world.robots=15".into()]).unwrap();
        assert_eq!(paper, Preset::Paper.config());
        let c = Config::resolve(Some("smoke"), None, &["run.tick_s=10".into()]).unwrap();
        assert_eq!(c.world.peer_refresh_s, 10.0);
        let c = Config::resolve(None, None, &["world.peer_refresh_s=2".into()]).unwrap();
        assert_eq!(c.world.peer_refresh_s, 2.0);
        // What the user set is never changed: the error names their own key.
        check_err(
            &["world.robots=5", "contract.penalised_ranks=2"],
            "`contract.penalised_ranks`: value 2 is out of range",
        );
        check_err(
            &["run.tick_s=1", "world.peer_refresh_s=0.5"],
            "`world.peer_refresh_s`: value 0.5",
        );
        // A preset value that conflicts with the user's and cannot be derived names both.
        check_err(
            &["data.input_waypoints=80"],
            "you did not set `data.target_waypoints` (preset `paper` gives it), but it no \
             longer fits what you set (data.input_waypoints)",
        );
    }

    #[test]
    fn text_parses_like_a_file_and_names_its_source() {
        let c =
            Config::from_toml_str("preset = \"smoke\"\n[world]\nrobots = 12\n", "mine").unwrap();
        assert_eq!((c.world.robots, c.preset.as_str()), (12, "smoke"));
        let paper = Config::from_toml_str("", "empty").unwrap();
        assert_eq!(paper, Preset::Paper.config());
        for (text, expect) in [
            ("[world\n", "invalid configuration in mine"),
            ("[world]\nrobots = \"x\"\n", "`world.robots (in mine)`"),
            ("preset = 3\n", "`preset (in mine)`"),
            ("preset = \"nope\"\n", "unknown preset \"nope\""),
            (
                "[world]\nrobots = 0\n",
                "`world.robots`: value 0 is out of range",
            ),
        ] {
            let err = Config::from_toml_str(text, "mine").unwrap_err().to_string();
            assert!(err.contains(expect), "{text:?}: {err:?} lacks {expect:?}");
        }
    }
}

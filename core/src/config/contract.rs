//! What the `contract` table names: the aggregation rule, the defence, the engine and the
//! authors' variant options. How each one computes lives in `contract/` (`rules/`,
//! `defences/`, `options.rs`, `evm/`).

use serde::{Deserialize, Serialize};

registry! {
    /// A contract aggregation rule (`contract.rule`): one line each, its name, its file
    /// (`in krum`: `contract/rules/krum.rs` and its type `krum::Krum`, declared and dispatched
    /// from the line by `Rule::aggregate`) and the smallest quorum it is defined for
    /// ([`Rule::min_quorum`]).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Rule => Quorum, files rule_files {
        /// Sample-weighted average of every valid model; no stakes, no threshold, no rewards
        /// (the paper's security off).
        Fedavg = "fedavg" in fedavg => Quorum::One,
        /// The paper's contract: outlier threshold, sample-weighted FedAvg of the accepted
        /// models, ranking by distance to the median distance, rewards and penalties.
        Paper = "paper" in paper => Quorum::One,
        /// Krum: the model with the smallest sum of squared distances to its `q - f - 2`
        /// nearest.
        Krum = "krum" in krum => Quorum::TwoFPlusThree,
        /// Multi-Krum: the unweighted mean of the `q - f` models with the best Krum scores.
        MultiKrum = "multi-krum" in multi_krum => Quorum::TwoFPlusThree,
        /// Coordinate-wise median.
        Median = "median" in median => Quorum::TwoFPlusOne,
        /// Coordinate-wise mean after dropping the `f` smallest and `f` largest values.
        TrimmedMean = "trimmed-mean" in trimmed_mean => Quorum::TwoFPlusOne,
        /// Geometric median by a fixed number of fixed-point Weiszfeld steps.
        Geomed = "geomed" in geomed => Quorum::TwoFPlusOne,
        /// Centered clipping around the shared model, radius the median distance.
        CenteredClipping = "centered-clipping" in centered_clipping => Quorum::TwoFPlusOne,
        /// Bulyan: `q - 2f` models chosen by iterated Krum, then a coordinate-wise trimmed
        /// mean.
        Bulyan = "bulyan" in bulyan => Quorum::FourFPlusThree,
        /// Minimum-diameter averaging: the mean of the `q - f` models of the smallest diameter.
        Mda = "mda" in mda => Quorum::TwoFPlusOne,
        /// Mean around the median: per weight, the mean of the `q - f` values nearest the
        /// median.
        Meamed = "meamed" in meamed => Quorum::TwoFPlusOne,
        /// MoNNA: the mean of the `q - f` models nearest the shared model.
        Monna = "monna" in monna => Quorum::TwoFPlusOne,
        /// SignGuard: norm and sign-statistics filters, then the mean clipped to the median
        /// norm.
        Signguard = "signguard" in signguard => Quorum::TwoFPlusOne,
        /// Divide and conquer: drop the `f` models farthest along the top principal direction.
        Dnc = "dnc" in dnc => Quorum::TwoFPlusOne,
        ; unlisted:
        /// A rule supplied by the program that runs the simulation (the Python package), named
        /// by `contract.rule_plugin`; not in [`Rule::ALL`], which lists the built-in rules. It
        /// is given `f` and the round's models and answers for itself.
        Plugin = "plugin" in plugin => Quorum::One,
    }
}

/// The smallest quorum an aggregation rule is defined for with `f` assumed Byzantine
/// submissions (a rule's line in the [`Rule`] registry).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quorum {
    /// Any non-empty round.
    One,
    /// `2f + 1`: a majority of honest models.
    TwoFPlusOne,
    /// `2f + 3`: Krum's `q - f - 2 >= 1` neighbours.
    TwoFPlusThree,
    /// `4f + 3`: Bulyan's `q - 2f` Krum selections, each with Krum's quorum.
    FourFPlusThree,
}

impl Quorum {
    /// The quorum with `f` assumed Byzantine submissions.
    pub const fn of(self, f: u32) -> u32 {
        match self {
            Quorum::One => 1,
            Quorum::TwoFPlusOne => 2 * f + 1,
            Quorum::TwoFPlusThree => 2 * f + 3,
            Quorum::FourFPlusThree => 4 * f + 3,
        }
    }
}

impl Rule {
    /// True when submissions stake tokens and the used ones are paid (every rule but fedavg).
    pub fn stakes(self) -> bool {
        self != Rule::Fedavg
    }

    /// The smallest quorum for which the rule is defined with `f` assumed Byzantine
    /// submissions: krum and multi-krum `2f + 3`, median, trimmed mean, geomed, centered
    /// clipping, mda, meamed, monna, signguard and dnc `2f + 1`, bulyan `4f + 3`, fedavg and
    /// paper 1; a plug-in rule 1 (it is given `f` and the round's models and answers for
    /// itself). Each rule's line in the registry says which.
    pub fn min_quorum(self, f: u32) -> u32 {
        self.spec().of(f)
    }
}

/// The most subsets one `mda` aggregation may visit (`C(q, f)`, `contract::rules::mda`);
/// validation keeps every configuration within it.
pub const MDA_MAX_SUBSETS: u64 = 1 << 20;

/// `C(q, f)`, the subsets `mda` visits with quorum `q`, or `None` above [`MDA_MAX_SUBSETS`].
pub fn mda_subsets(q: u64, f: u64) -> Option<u64> {
    let k = f.min(q.saturating_sub(f));
    let mut c: u128 = 1;
    for i in 0..k {
        // C(q, i + 1) = C(q, i) (q - i) / (i + 1), exact at every step.
        c = c * u128::from(q - i) / u128::from(i + 1);
        if c > u128::from(MDA_MAX_SUBSETS) {
            return None;
        }
    }
    u64::try_from(c).ok()
}

/// A defence of the reward rule (`contract.defence`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Defence {
    /// The rule's own rewards (the paper's ranking, or equal shares).
    #[default]
    None,
    /// Pay by leave-one-out agreement of the centered updates.
    Agreement,
    /// Pay by leave-one-out agreement of the updates' parts the last step does not predict.
    Innovation,
}

impl Defence {
    /// Every variant, in documentation order.
    pub const ALL: [Defence; 3] = [Defence::None, Defence::Agreement, Defence::Innovation];

    /// The defence's name as written in configurations.
    pub fn name(self) -> &'static str {
        match self {
            Defence::None => "none",
            Defence::Agreement => "agreement",
            Defence::Innovation => "innovation",
        }
    }

    /// Looks a defence up by its configuration name.
    pub fn from_name(name: &str) -> Option<Defence> {
        Defence::ALL.into_iter().find(|d| d.name() == name)
    }
}

/// How the contract turns submissions into model versions (`contract.protocol`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RoundProtocol {
    /// The paper's rounds: every submission is judged against the newest shared model, a
    /// robot submits once per round, the round closes at the quorum.
    #[default]
    Rounds,
    /// Buffered, staleness-aware aggregation (issue 32, FedBuff with FedAsync's staleness
    /// weight): a submission names the model version it trained from and is judged against
    /// it; every `contract.buffer_size` accepted updates move the model (`contract/buffered.rs`).
    Buffered,
}

impl RoundProtocol {
    /// The protocol's name as written in configurations.
    pub fn name(self) -> &'static str {
        match self {
            RoundProtocol::Rounds => "rounds",
            RoundProtocol::Buffered => "buffered",
        }
    }
}

/// How the buffered protocol's outlier check sets its bound (`contract.outlier_rule`; beyond
/// the paper, issue #32; `contract/outlier.rs` has the rule and its analysis).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OutlierRule {
    /// The paper's: a fixed bound, `contract.outlier_threshold`.
    #[default]
    Absolute,
    /// `contract.outlier_factor` times the median distance of the accepted updates of the
    /// last `contract.outlier_window` closed buffers, never below `contract.outlier_threshold`
    /// nor above `contract.outlier_cap`.
    Relative,
}

impl OutlierRule {
    /// The rule's name as written in configurations.
    pub fn name(self) -> &'static str {
        match self {
            OutlierRule::Absolute => "absolute",
            OutlierRule::Relative => "relative",
        }
    }
}

/// Which machine executes the contract.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ContractEngine {
    /// The Rust reducer of `contract/mod.rs`.
    #[default]
    Native,
    /// The Solidity contract of `contracts/SwarmFL.sol`, its committed bytecode run in revm.
    Evm,
}

/// The gas limit a robot's transaction carries under `contract.engine = "evm"`
/// (`contract.gas_limit`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GasLimitRule {
    /// The block's gas limit (`contract.block_gas_limit`): gas never decides an outcome below
    /// it (swarmfl).
    #[default]
    Block,
    /// The gas the call uses on the state the sender's node holds when it sends, plus
    /// `contract.gas_margin` (the authors' web3.py: estimate plus 100000).
    Estimate,
}

impl GasLimitRule {
    /// The configuration name.
    pub fn name(self) -> &'static str {
        match self {
            GasLimitRule::Block => "block",
            GasLimitRule::Estimate => "estimate",
        }
    }
}

/// The state a node estimates a transaction's gas on under `contract.gas_limit = "estimate"`
/// (`contract.gas_estimate_state`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GasEstimateState {
    /// The block its miner would seal next: its head state, then the transactions of its
    /// mempool that block would take (geth's `eth_estimateGas` without a block, as web3.py
    /// calls it).
    #[default]
    Pending,
    /// Its head block's state alone (`eth_estimateGas` at `latest`).
    Head,
}

impl GasEstimateState {
    /// The configuration name.
    pub fn name(self) -> &'static str {
        match self {
            GasEstimateState::Pending => "pending",
            GasEstimateState::Head => "head",
        }
    }
}

/// The median of an even number of distances.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MedianRule {
    /// The lower middle `sorted[(q - 1) / 2]` (swarmfl).
    #[default]
    Lower,
    /// The floored mean of the two middles (authors).
    Mean,
}

/// How FedAvg's quotient is rounded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FedAvgRounding {
    /// To the nearest integer, ties away from zero (swarmfl).
    #[default]
    Nearest,
    /// Toward zero, Solidity's signed division (authors).
    Truncate,
}

/// When a distance equal to the threshold is accepted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ThresholdRule {
    /// Accepted iff `d <= threshold * N` (swarmfl, the paper's "<=").
    #[default]
    Inclusive,
    /// Accepted iff `d < threshold * N` (authors: `floor(d / N) < threshold`).
    Strict,
}

/// The distance the ranking is computed on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RankKey {
    /// The exact L1 distance `d` (swarmfl).
    #[default]
    Distance,
    /// The truncated mean absolute error `floor(d / N)` (authors), which creates ties.
    Mae,
}

/// Which accepted submission the paper's ranking puts first (`contract.rank_order`; beyond
/// the paper, issue #36: the counterfactual of claim 12, `contract/rank_order.rs`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RankOrder {
    /// Closest to the median distance first, `|d_k - median(d)|` (the paper's).
    #[default]
    Median,
    /// Closest to the shared model first, `d_k` ascending: no submission's rank depends on
    /// where the others put the median.
    Nearest,
}

impl RankOrder {
    /// The order's name as written in configurations.
    pub fn name(self) -> &'static str {
        match self {
            RankOrder::Median => "median",
            RankOrder::Nearest => "nearest",
        }
    }

    /// True for the paper's order (the default, left out of every encoding).
    pub fn is_median(&self) -> bool {
        *self == RankOrder::Median
    }
}

/// How equal ranking keys are ordered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RankTies {
    /// Submission order (a stable sort; swarmfl).
    #[default]
    Stable,
    /// Whatever the authors' Hoare quicksort leaves (not stable).
    Quicksort,
}

/// How the reward and penalty shares are rounded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PayoutRounding {
    /// `floor(stake * k s / sum)` rewards, `ceil(..)` penalties (swarmfl: exact to one unit).
    #[default]
    #[serde(rename = "exact")]
    Exact,
    /// The share normalised to 1e9 and floored first, `stake * floor(1e9 k s / sum) / 1e9`,
    /// for rewards and penalties alike (authors).
    #[serde(rename = "ratio_1e9")]
    Ratio1e9,
}

/// What an aggregation distributes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PoolRule {
    /// Everything the contract holds: the round's stakes plus earlier remainders (swarmfl).
    #[default]
    Carry,
    /// The round's stakes only; remainders stay in the contract for good (authors).
    Round,
}

/// Every variant option of the contract (all default: swarmfl's rules).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContractOptions {
    /// `contract.median`.
    pub median: MedianRule,
    /// `contract.fedavg_rounding`.
    pub fedavg_rounding: FedAvgRounding,
    /// `contract.int48_products`: refuse an accepted model when some `w_i * n`, or the round's
    /// running sum with it, leaves int48 (the authors' `int48` accumulator under Solidity 0.8's
    /// checked arithmetic reverts such a submission).
    pub int48_products: bool,
    /// `contract.threshold`.
    pub threshold: ThresholdRule,
    /// `contract.rank_key`.
    pub rank_key: RankKey,
    /// `contract.rank_ties`.
    pub rank_ties: RankTies,
    /// `contract.payout_rounding`.
    pub payout_rounding: PayoutRounding,
    /// `contract.pool`.
    pub pool: PoolRule,
    /// `contract.rank_order` (not one of the authors' variants: both contracts rank around
    /// the median). Left out of the encoding at its default, so the genesis parameters of
    /// every run that ranks around the median (the authors' options included) keep their
    /// bytes.
    #[serde(default, skip_serializing_if = "RankOrder::is_median")]
    pub rank_order: RankOrder,
}

//! The state at one block of the final canonical chain: what `swarmfl inspect --block H` shows,
//! from an index made for that block (from the sidecar, folding only up to the block: `seek.rs`).

use serde::Serialize;

use super::error::InspectError;
use super::fold::LastLearning;
use super::index::{BlockRow, RunIndex};
use crate::config::{Behaviour, Config};
use crate::contract::{Call, ContractState, Outcome, Submission, Verdict};
use crate::ledger::{BlockEntry, BlockHash};
use crate::metrics::LearnReport;
use crate::state::State;
use crate::types::RobotId;

/// What `swarmfl inspect` shows about one block.
#[derive(Clone, Debug, Serialize)]
pub struct BlockReport {
    /// The log.
    pub log: String,
    /// The block.
    pub block: BlockInfo,
    /// The contract state after it.
    pub contract: ContractInfo,
    /// Every node's head right after it was sealed.
    pub nodes: Vec<NodeInfo>,
    /// The world at that moment.
    pub world: WorldInfo,
    /// One robot's view, when asked for.
    pub robot: Option<RobotView>,
}

/// A block's header and transactions.
#[derive(Clone, Debug, Serialize)]
pub struct BlockInfo {
    /// Height.
    pub height: u64,
    /// Id (hex).
    pub hash: String,
    /// Parent id (hex).
    pub parent: String,
    /// Timestamp, s.
    pub time_s: f64,
    /// The sealing robot (`None` for genesis).
    pub signer: Option<RobotId>,
    /// Clique difficulty.
    pub difficulty: u64,
    /// Total difficulty of the chain up to it.
    pub total_difficulty: u64,
    /// Size of the chain up to it, bytes.
    pub chain_bytes: u64,
    /// Index of its sealing checkpoint record (an equivocator's twin: of the injection that
    /// stored it; see [`super::index::BlockRow::record`]).
    pub record: Option<u64>,
    /// Its transactions with their outcomes.
    pub txs: Vec<TxInfo>,
}

/// One transaction of a block.
#[derive(Clone, Debug, Serialize)]
pub struct TxInfo {
    /// Id (hex).
    pub hash: String,
    /// Sender.
    pub sender: RobotId,
    /// Whether the sender is Byzantine.
    pub byzantine: bool,
    /// `submit(n=..)` or `transfer(to=.., tokens)`.
    pub call: String,
    /// Stake sent with it, tokens.
    pub value_tokens: f64,
    /// The outcome's name.
    pub outcome: String,
    /// The outcome's details (round, distance, reason).
    pub detail: String,
}

/// The contract state after a block.
#[derive(Clone, Debug, Serialize)]
pub struct ContractInfo {
    /// Rounds closed so far, which is also the shared model's version and the number of the
    /// last closed round (rounds are numbered from 1 everywhere); round `round + 1` is open.
    pub round: u64,
    /// Digest of the shared model (hex).
    pub model_digest: String,
    /// Every robot's balance.
    pub balances: Vec<BalanceInfo>,
    /// Units held by the contract (the pool), tokens.
    pub pool_tokens: f64,
    /// The current round's counted submissions.
    pub submissions: Vec<SubmissionInfo>,
    /// The last closed round.
    pub last_round: Option<RoundInfo>,
}

/// A robot's balance.
#[derive(Clone, Debug, Serialize)]
pub struct BalanceInfo {
    /// The robot.
    pub robot: RobotId,
    /// Balance, tokens.
    pub tokens: f64,
    /// Whether it is Byzantine.
    pub byzantine: bool,
}

/// A counted submission of a round.
#[derive(Clone, Debug, Serialize)]
pub struct SubmissionInfo {
    /// The sender.
    pub sender: RobotId,
    /// Whether it is Byzantine.
    pub byzantine: bool,
    /// Samples claimed.
    pub samples: u64,
    /// Distance to the shared model, fixed-point units summed over the weights.
    pub distance_units: u64,
    /// The same distance as the mean per weight in model units (what
    /// `contract.outlier_threshold` is compared with).
    pub distance_per_weight: f64,
    /// Stake, tokens.
    pub stake_tokens: f64,
    /// `accepted` or `outlier`.
    pub verdict: String,
}

/// The last closed round and its payouts.
#[derive(Clone, Debug, Serialize)]
pub struct RoundInfo {
    /// The round, numbered from 1 (the run summary's `r1` is round 1).
    pub round: u64,
    /// Its counted submissions.
    pub submissions: Vec<SubmissionInfo>,
    /// The distributed pool, tokens.
    pub pool_tokens: f64,
    /// What stayed in the contract, tokens.
    pub carried_tokens: f64,
    /// Payouts in rank order: (robot, rank, reward weight, tokens).
    pub payouts: Vec<(RobotId, u32, i64, f64)>,
}

/// A node's head.
#[derive(Clone, Debug, Serialize)]
pub struct NodeInfo {
    /// The node.
    pub node: RobotId,
    /// Its head's id (hex).
    pub head: String,
    /// Its head's height.
    pub height: u64,
    /// Whether its head is on the final canonical chain.
    pub on_final_chain: bool,
}

/// The world at a block's time.
#[derive(Clone, Debug, Serialize)]
pub struct WorldInfo {
    /// Simulated time of the state, s.
    pub time_s: f64,
    /// Every robot.
    pub robots: Vec<RobotInfo>,
}

/// One robot in the world.
#[derive(Clone, Debug, Serialize)]
pub struct RobotInfo {
    /// The robot.
    pub robot: RobotId,
    /// Whether it is Byzantine.
    pub byzantine: bool,
    /// Position, m.
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Heading, rad.
    pub theta: f64,
    /// Peers in contact.
    pub peers: usize,
    /// Samples in its data set.
    pub dataset: usize,
    /// Its behaviour (`world.behaviour`; each robot's own in a `mixed` swarm).
    pub behaviour: &'static str,
    /// A forager's state (`explore`, `return` or `rest`); absent for other behaviours.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub forager: Option<&'static str>,
}

/// One robot's view of the run at a block.
#[derive(Clone, Debug, Serialize)]
pub struct RobotView {
    /// The robot.
    pub robot: RobotId,
    /// Whether it is Byzantine.
    pub byzantine: bool,
    /// Its node's head.
    pub node: NodeInfo,
    /// Rounds closed at its own head (its model version; round `round + 1` is open there).
    pub round: u64,
    /// Its balance at its own head, tokens.
    pub balance_tokens: f64,
    /// Its pose and data.
    pub world: RobotInfo,
    /// Its peers.
    pub peers: Vec<RobotId>,
    /// Its last learning report until then: (time s, description).
    pub last_learning: Option<(f64, String)>,
}

/// Builds the report of block `height` from an index made with `index_run(path, Some(height))`.
pub fn block_report(
    index: &RunIndex,
    height: u64,
    robot: Option<RobotId>,
) -> Result<BlockReport, InspectError> {
    let (state, learned) = index
        .at_block
        .as_ref()
        .expect("the index was made for this block");
    let canonical: std::collections::BTreeSet<BlockHash> =
        index.chain.iter().map(|r| r.hash).collect();
    ReportInput {
        path: &index.path,
        config: &index.config,
        byzantine: &index.byzantine,
        canonical: &canonical,
        row: &index.chain[height as usize],
        state,
        learned,
    }
    .report(robot)
}

/// Everything a block report is made from.
pub(super) struct ReportInput<'a> {
    pub(super) path: &'a str,
    pub(super) config: &'a Config,
    pub(super) byzantine: &'a [bool],
    pub(super) canonical: &'a std::collections::BTreeSet<BlockHash>,
    pub(super) row: &'a BlockRow,
    pub(super) state: &'a State,
    pub(super) learned: &'a LastLearning,
}

impl ReportInput<'_> {
    /// The report, with `robot`'s view when asked for.
    pub(super) fn report(&self, robot: Option<RobotId>) -> Result<BlockReport, InspectError> {
        let robots = self.config.world.robots;
        if let Some(r) = robot {
            if r >= robots {
                return Err(InspectError::NoRobot { robot: r, robots });
            }
        }
        let row = self.row;
        // The block was sealed by then, so the state's own ledger has it and its transactions.
        let entry =
            self.state
                .ledger
                .block(&row.hash)
                .ok_or_else(|| InspectError::Inconsistent {
                    path: self.path.to_string(),
                    message: format!("block {} is not known at its sealing", row.hash.short()),
                })?;
        let header = &entry.block.header;
        Ok(BlockReport {
            log: self.path.to_string(),
            block: BlockInfo {
                height: row.height,
                hash: row.hash.to_hex(),
                parent: header.parent.to_hex(),
                time_s: row.time.secs(),
                signer: (row.height > 0).then_some(header.signer),
                difficulty: header.difficulty,
                total_difficulty: entry.total_difficulty,
                chain_bytes: entry.chain_bytes,
                record: row.record,
                txs: self.txs(entry),
            },
            contract: self.contract(&entry.state),
            nodes: (0..robots).map(|r| self.node(r)).collect(),
            world: WorldInfo {
                time_s: self.state.world.time().secs(),
                robots: (0..robots).map(|r| self.robot(r)).collect(),
            },
            robot: robot.map(|r| self.view(r)),
        })
    }

    /// Tokens of `units`.
    /// A submission's distance as `run` prints it: the mean per weight in model units, beside
    /// the threshold it was compared with and the raw units the receipt holds.
    fn distance(&self, units: u64) -> String {
        let params = self.state.ledger.params();
        let per_weight = params.distance_per_weight(units, self.config.contract.weight_scale);
        format!(
            "{per_weight:.4} per weight (threshold {}; {units} units)",
            self.config.contract.outlier_threshold
        )
    }

    fn tokens(&self, units: u64) -> f64 {
        units as f64 / self.config.contract.token_units as f64
    }

    /// Whether robot `r` is Byzantine.
    fn byz(&self, r: RobotId) -> bool {
        self.byzantine.get(r as usize).copied().unwrap_or(false)
    }

    /// The block's transactions with their outcomes.
    fn txs(&self, entry: &BlockEntry) -> Vec<TxInfo> {
        entry
            .block
            .txs
            .iter()
            .zip(entry.receipts.iter())
            .map(|(h, outcome)| {
                let tx = self.state.ledger.tx(h).map(|t| t.tx.clone());
                let (sender, value, call) = match tx.as_deref() {
                    Some(t) => (
                        t.sender,
                        t.value_units,
                        match &t.call {
                            Call::SubmitModel { samples, .. } => format!("submit(n={samples})"),
                            Call::SubmitUpdate {
                                samples,
                                base_round,
                                ..
                            } => format!("submit(n={samples}, base version {base_round})"),
                            Call::Transfer { to, amount_units } => {
                                format!("transfer(to={to}, {} tokens)", self.tokens(*amount_units))
                            }
                        },
                    ),
                    None => (RobotId::MAX, 0, "?".to_string()),
                };
                TxInfo {
                    hash: h.to_hex(),
                    sender,
                    byzantine: self.byz(sender),
                    call,
                    value_tokens: self.tokens(value),
                    outcome: outcome.name().to_string(),
                    detail: outcome_detail(outcome, |units| self.distance(units)),
                }
            })
            .collect()
    }

    /// A counted submission.
    fn submission(&self, s: &Submission) -> SubmissionInfo {
        SubmissionInfo {
            sender: s.sender,
            byzantine: self.byz(s.sender),
            samples: s.samples,
            distance_units: s.distance_units,
            distance_per_weight: self
                .state
                .ledger
                .params()
                .distance_per_weight(s.distance_units, self.config.contract.weight_scale),
            stake_tokens: self.tokens(s.stake_units),
            verdict: match s.verdict {
                Verdict::Accepted => "accepted",
                Verdict::Outlier => "outlier",
            }
            .to_string(),
        }
    }

    /// The contract state after the block.
    fn contract(&self, cs: &ContractState) -> ContractInfo {
        ContractInfo {
            round: cs.round,
            model_digest: cs.weights_digest.to_hex(),
            balances: cs
                .balances
                .iter()
                .enumerate()
                .map(|(r, &u)| BalanceInfo {
                    robot: r as RobotId,
                    tokens: self.tokens(u),
                    byzantine: self.byz(r as RobotId),
                })
                .collect(),
            pool_tokens: self.tokens(cs.holdings_units),
            submissions: cs.submissions.iter().map(|s| self.submission(s)).collect(),
            last_round: cs.last_round.as_ref().map(|s| RoundInfo {
                round: s.round + 1,
                submissions: s.submissions.iter().map(|x| self.submission(x)).collect(),
                pool_tokens: self.tokens(s.pool_units),
                carried_tokens: self.tokens(s.carried_units),
                payouts: s
                    .payouts
                    .iter()
                    .map(|p| (p.robot, p.rank, p.reward_weight, self.tokens(p.units)))
                    .collect(),
            }),
        }
    }

    /// Node `r`'s head.
    fn node(&self, r: RobotId) -> NodeInfo {
        let (head, h) = self.state.ledger.head(r);
        NodeInfo {
            node: r,
            head: head.to_hex(),
            height: h,
            on_final_chain: self.canonical.contains(&head),
        }
    }

    /// Robot `r` in the world.
    fn robot(&self, r: RobotId) -> RobotInfo {
        let world = &self.state.world;
        let pose = world.poses()[r as usize];
        RobotInfo {
            robot: r,
            byzantine: self.byz(r),
            x: pose.x,
            y: pose.y,
            theta: pose.theta,
            peers: world.peers(r).len(),
            dataset: world.dataset_len(r),
            behaviour: world
                .behaviours()
                .map_or(Behaviour::Avoidance, |b| b.of[r as usize])
                .name(),
            forager: world
                .behaviours()
                .filter(|b| b.of[r as usize] == Behaviour::Foraging)
                .map(|b| b.foragers[r as usize].name()),
        }
    }

    /// Robot `r`'s own view.
    fn view(&self, r: RobotId) -> RobotView {
        let own = self.state.ledger.head_state(r);
        RobotView {
            robot: r,
            byzantine: self.byz(r),
            node: self.node(r),
            round: own.round,
            balance_tokens: self.tokens(own.balances[r as usize]),
            world: self.robot(r),
            peers: self.state.world.peers(r).to_vec(),
            last_learning: self.learned[r as usize]
                .as_ref()
                .map(|(t, report)| (t.secs(), describe_learning(report))),
        }
    }
}

fn outcome_detail(outcome: &Outcome, distance: impl Fn(u64) -> String) -> String {
    match outcome {
        Outcome::Accepted {
            round,
            distance_units,
        } => format!(
            "round {}, distance {}",
            round + 1,
            distance(*distance_units)
        ),
        Outcome::Aggregated {
            round,
            distance_units,
            payouts,
        } => format!(
            "closed round {}, distance {}, {} payouts",
            round + 1,
            distance(*distance_units),
            payouts.len()
        ),
        Outcome::Outlier {
            round,
            distance_units,
        } => format!(
            "round {}, distance {}",
            round + 1,
            distance(*distance_units)
        ),
        Outcome::Malformed(reason) => reason.clone(),
        Outcome::Refused(refusal) => refusal.reason(),
        Outcome::OverGasLimit { gas_limit } => {
            format!("needs more gas than a block holds (contract.block_gas_limit {gas_limit})")
        }
        Outcome::OutOfGas { gas_limit } => format!(
            "ran out of its {gas_limit} gas and reverted (contract.gas_limit = estimate: its \
             node's estimate plus contract.gas_margin); its stake stayed with it"
        ),
        _ => String::new(),
    }
}

fn describe_learning(report: &LearnReport) -> String {
    use crate::metrics::LearnAction;
    match &report.action {
        LearnAction::Trained {
            tx,
            train_samples,
            val_samples,
            val_loss,
            final_train_loss,
        } => format!(
            "trained for round {} ({train_samples} train / {val_samples} validation samples): val loss {val_loss:.6}, train loss {final_train_loss:.6}; submitted tx {}",
            report.base_round + 1,
            tx.short()
        ),
        LearnAction::Forged {
            tx,
            claimed_samples,
        } => format!(
            "forged a model for round {} claiming {claimed_samples} samples; submitted tx {}",
            report.base_round + 1,
            tx.short()
        ),
        LearnAction::Skipped { reason } => {
            format!("skipped round {}: {}", report.base_round + 1, reason.name())
        }
    }
}

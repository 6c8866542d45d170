//! A run's tables as typed columns: what `swarmfl export` writes as CSV and what the Python
//! package hands to pandas (one array per column, never a row at a time). One place builds
//! them, so the CSV files and the data frames always agree.
//!
//! Every aggregation has rounds: a chain run's are the closed rounds of its final canonical
//! chain; a baseline's (`gossip`, `central`) are its aggregations as `summary.json` counts them
//! (honest robots' merges from a quorum, or the server's rounds), with the same loss and
//! held-out loss. Tables about tokens and blocks (submissions, balances, chain sizes) exist
//! only for a chain run; asking a baseline for one is an error that says why.

use std::path::Path;

use super::error::InspectError;
use super::expr::Env;
use super::index::RunIndex;
use crate::aggregation;
use crate::config::Aggregation;
use crate::contract::{Call, Outcome, Verdict};
use crate::event::{Event, Record};
use crate::log::LogReader;
use crate::replay::{header_config, ReplayError};
use crate::state::State;

/// One column's values.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// Unsigned integers.
    U64(Vec<u64>),
    /// Signed integers.
    I64(Vec<i64>),
    /// Floats (NaN where a value is not defined).
    F64(Vec<f64>),
    /// Single-precision floats (waypoints are stored as such; kept so, the CSV text is
    /// the value's own shortest form).
    F32(Vec<f32>),
    /// Booleans.
    Bool(Vec<bool>),
    /// Text.
    Str(Vec<String>),
}

impl Column {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            Column::U64(v) => v.len(),
            Column::I64(v) => v.len(),
            Column::F64(v) => v.len(),
            Column::F32(v) => v.len(),
            Column::Bool(v) => v.len(),
            Column::Str(v) => v.len(),
        }
    }

    /// Whether the column is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `row` as CSV text (Rust's `to_string`, as `export` always wrote: `NaN`, `true`).
    pub fn cell(&self, row: usize) -> String {
        match self {
            Column::U64(v) => v[row].to_string(),
            Column::I64(v) => v[row].to_string(),
            Column::F64(v) => v[row].to_string(),
            Column::F32(v) => v[row].to_string(),
            Column::Bool(v) => v[row].to_string(),
            Column::Str(v) => v[row].clone(),
        }
    }
}

/// Named columns of equal length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// The columns in order.
    pub columns: Vec<(&'static str, Column)>,
}

impl Table {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, |(_, c)| c.len())
    }

    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, c)| c)
    }

    /// Column names in order.
    pub fn names(&self) -> Vec<&'static str> {
        self.columns.iter().map(|(n, _)| *n).collect()
    }

    pub(super) fn push(&mut self, name: &'static str, column: Column) {
        debug_assert!(
            self.columns.is_empty() || column.len() == self.rows(),
            "columns of one table have one length"
        );
        self.columns.push((name, column));
    }
}

/// Why a baseline run has no table of this kind.
fn chain_only(index: &RunIndex, what: &str) -> Result<(), InspectError> {
    let kind = index.config.learn.aggregation;
    if kind == Aggregation::Chain {
        return Ok(());
    }
    Err(InspectError::Inconsistent {
        path: index.path.clone(),
        message: format!(
            "a {} run has no {what}: it has no blocks, no contract and no tokens (learn.aggregation = \"{}\"); its rounds table lists its aggregations",
            kind.name(),
            kind.name()
        ),
    })
}

impl RunIndex {
    /// The rounds of the run, for every aggregation (module docs).
    ///
    /// Chain: `round`, `block`, `time_s`, `loss`, `heldout_loss` (of the shared model after the
    /// closing block), `accepted`, `outliers`, `mean_honest_distance`. Baselines: `round`,
    /// `time_s`, `robot` (`gossip`: the merging robot; `central`: -1, the server), `models`
    /// (averaged), `loss`, `heldout_loss` (of the aggregated model).
    pub fn rounds_table(&self) -> Result<Table, InspectError> {
        if self.config.learn.aggregation != Aggregation::Chain {
            return Ok(self.baseline_rounds());
        }
        let values = self.values();
        let rounds = self.rounds();
        let mut heldout = Vec::with_capacity(rounds.len());
        for r in &rounds {
            heldout.push(values.at(r.block).ident("heldout_loss").map_err(|source| {
                InspectError::Eval {
                    block: r.block,
                    cause: source,
                }
            })?);
        }
        let mut t = Table::default();
        t.push(
            "round",
            Column::U64(rounds.iter().map(|r| r.round).collect()),
        );
        t.push(
            "block",
            Column::U64(rounds.iter().map(|r| r.block).collect()),
        );
        t.push(
            "time_s",
            Column::F64(rounds.iter().map(|r| r.time_s).collect()),
        );
        t.push("loss", Column::F64(rounds.iter().map(|r| r.loss).collect()));
        t.push("heldout_loss", Column::F64(heldout));
        t.push(
            "accepted",
            Column::U64(rounds.iter().map(|r| r.accepted).collect()),
        );
        t.push(
            "outliers",
            Column::U64(rounds.iter().map(|r| r.outliers).collect()),
        );
        t.push(
            "mean_honest_distance",
            Column::F64(rounds.iter().map(|r| r.mean_honest_distance).collect()),
        );
        Ok(t)
    }

    /// A baseline's aggregations, as `summary.json` counts them (the same call computes both).
    fn baseline_rounds(&self) -> Table {
        let state = &self.final_state;
        let (contract, _) = aggregation::summary::summarise(
            &self.config,
            &state.aggregation,
            &state.metrics,
            state.world.heldout(),
            &self.byzantine,
        );
        let is_byzantine = |r: u32| self.byzantine.get(r as usize).copied().unwrap_or(false);
        let records: Vec<_> = state
            .aggregation
            .aggregations
            .iter()
            .filter(|a| a.robot.is_none_or(|r| !is_byzantine(r)))
            .collect();
        let mut t = Table::default();
        t.push("round", Column::U64((1..=records.len() as u64).collect()));
        t.push(
            "time_s",
            Column::F64(records.iter().map(|a| a.time.secs()).collect()),
        );
        t.push(
            "robot",
            Column::I64(
                records
                    .iter()
                    .map(|a| a.robot.map_or(-1, i64::from))
                    .collect(),
            ),
        );
        t.push(
            "models",
            Column::U64(records.iter().map(|a| a.models.len() as u64).collect()),
        );
        t.push("loss", Column::F64(contract.loss_by_round));
        t.push("heldout_loss", Column::F64(contract.heldout_loss_by_round));
        t
    }

    /// Every counted submission of every closed round of the final canonical chain (accepted
    /// and outliers, in submission order): `round`, `block` (that closed it), `robot`,
    /// `byzantine`, `outcome` (`accepted` or `outlier`), `distance` (mean absolute distance per weight to
    /// the round's model, in model units), `samples` (claimed), `stake_tokens`,
    /// `reward_tokens` (paid back from the pool; 0 when not paid: an outlier, a model a robust
    /// rule did not use, or any model with security off).
    pub fn submissions_table(&self) -> Result<Table, InspectError> {
        chain_only(self, "submissions table")?;
        let params = self.final_state.ledger.params();
        let scale = self.config.contract.weight_scale;
        let (mut round, mut block, mut robot, mut byz, mut outcome) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut distance, mut samples, mut stake, mut reward) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (height, summary) in self.closed_rounds() {
            for s in &summary.submissions {
                let paid = summary.payouts.iter().find(|p| p.robot == s.sender);
                round.push(summary.round + 1);
                block.push(height);
                robot.push(u64::from(s.sender));
                byz.push(is_byzantine(&self.byzantine, s.sender));
                outcome.push(
                    match s.verdict {
                        Verdict::Accepted => "accepted",
                        Verdict::Outlier => "outlier",
                    }
                    .to_string(),
                );
                distance.push(params.distance_per_weight(s.distance_units, scale));
                samples.push(s.samples);
                stake.push(self.tokens(s.stake_units));
                reward.push(paid.map_or(0.0, |p| self.tokens(p.units)));
            }
        }
        let mut t = Table::default();
        t.push("round", Column::U64(round));
        t.push("block", Column::U64(block));
        t.push("robot", Column::U64(robot));
        t.push("byzantine", Column::Bool(byz));
        t.push("outcome", Column::Str(outcome));
        t.push("distance", Column::F64(distance));
        t.push("samples", Column::U64(samples));
        t.push("stake_tokens", Column::F64(stake));
        t.push("reward_tokens", Column::F64(reward));
        Ok(t)
    }

    /// Every robot's balance after every block of the final canonical chain: `block`,
    /// `time_s`, `robot`, `balance_tokens`, `byzantine`.
    pub fn balances_table(&self) -> Result<Table, InspectError> {
        chain_only(self, "balances")?;
        let (mut block, mut time, mut robot, mut balance, mut byz) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for row in &self.chain {
            let state = self.contract_at(row.height);
            for (r, &units) in state.balances.iter().enumerate() {
                block.push(row.height);
                time.push(row.time.secs());
                robot.push(r as u64);
                balance.push(self.tokens(units));
                byz.push(self.byzantine[r]);
            }
        }
        let mut t = Table::default();
        t.push("block", Column::U64(block));
        t.push("time_s", Column::F64(time));
        t.push("robot", Column::U64(robot));
        t.push("balance_tokens", Column::F64(balance));
        t.push("byzantine", Column::Bool(byz));
        Ok(t)
    }

    /// Every model submission on the final canonical chain, refused ones included (the
    /// submissions table holds only those a round counted): `block`, `time_s`, `robot`,
    /// `byzantine`, `samples` (claimed), `outcome` (the receipt's: `accepted`, `aggregated`,
    /// `outlier`, `duplicate`, `insufficient_stake`, `malformed`, ...) and `reason` (a
    /// malformed or refused call's reason, else empty).
    pub fn outcomes_table(&self) -> Result<Table, InspectError> {
        chain_only(self, "outcomes")?;
        let (mut block, mut time, mut robot, mut byz) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut samples, mut outcome, mut reason) = (Vec::new(), Vec::new(), Vec::new());
        let ledger = &self.final_state.ledger;
        for row in &self.chain {
            let entry = ledger
                .block(&row.hash)
                .expect("canonical blocks are stored");
            for (hash, receipt) in entry.block.txs.iter().zip(entry.receipts.iter()) {
                let Some(tx) = ledger.tx(hash) else { continue };
                let claimed = match &tx.tx.call {
                    Call::SubmitModel { samples, .. } | Call::SubmitUpdate { samples, .. } => {
                        *samples
                    }
                    Call::Transfer { .. } => continue,
                };
                block.push(row.height);
                time.push(row.time.secs());
                robot.push(u64::from(tx.tx.sender));
                byz.push(is_byzantine(&self.byzantine, tx.tx.sender));
                samples.push(claimed);
                outcome.push(receipt.name().to_string());
                reason.push(match receipt {
                    Outcome::Malformed(why) => why.clone(),
                    Outcome::Refused(r) => r.reason(),
                    _ => String::new(),
                });
            }
        }
        let mut t = Table::default();
        t.push("block", Column::U64(block));
        t.push("time_s", Column::F64(time));
        t.push("robot", Column::U64(robot));
        t.push("byzantine", Column::Bool(byz));
        t.push("samples", Column::U64(samples));
        t.push("outcome", Column::Str(outcome));
        t.push("reason", Column::Str(reason));
        Ok(t)
    }

    /// Every node's canonical chain size at every sealing (any node's): `time_s`, `node`,
    /// `chain_bytes`.
    pub fn chain_bytes_table(&self) -> Result<Table, InspectError> {
        chain_only(self, "chain sizes")?;
        let (mut time, mut node, mut bytes) = (Vec::new(), Vec::new(), Vec::new());
        for row in &self.chain_bytes {
            for (n, &b) in row.bytes.iter().enumerate() {
                time.push(row.time.secs());
                node.push(n as u64);
                bytes.push(b);
            }
        }
        let mut t = Table::default();
        t.push("time_s", Column::F64(time));
        t.push("node", Column::U64(node));
        t.push("chain_bytes", Column::U64(bytes));
        Ok(t)
    }

    /// The samples of every robot's data set at the end of the run (expired ones are gone),
    /// one row per waypoint: `robot`, `sample`, `completed_s`, `point`, `x`, `y`.
    pub fn trajectories_table(&self) -> Table {
        let world = &self.final_state.world;
        let (mut robot, mut sample, mut completed) = (Vec::new(), Vec::new(), Vec::new());
        let (mut point, mut xs, mut ys) = (Vec::new(), Vec::new(), Vec::new());
        for r in 0..self.config.world.robots {
            for (i, s) in world.dataset(r).iter().enumerate() {
                for (p, [x, y]) in s.points.iter().enumerate() {
                    robot.push(u64::from(r));
                    sample.push(i as u64);
                    completed.push(s.time.secs());
                    point.push(p as u64);
                    xs.push(*x);
                    ys.push(*y);
                }
            }
        }
        let mut t = Table::default();
        t.push("robot", Column::U64(robot));
        t.push("sample", Column::U64(sample));
        t.push("completed_s", Column::F64(completed));
        t.push("point", Column::U64(point));
        t.push("x", Column::F32(xs));
        t.push("y", Column::F32(ys));
        t
    }
}

fn is_byzantine(byzantine: &[bool], robot: u32) -> bool {
    byzantine.get(robot as usize).copied().unwrap_or(false)
}

/// Every robot's pose every `every_s` simulated seconds (from t = 0, then at the first tick
/// at or past each multiple), from a fold of the log's ticks alone (the world's reducer; the
/// ledger is not folded, so this is cheap): `time_s`, `robot`, `x`, `y`, `theta` (radians).
/// Works for every aggregation. The log's hash chain is verified as it is read.
pub fn poses_table(path: &Path, every_s: f64) -> Result<Table, InspectError> {
    let name = path.display().to_string();
    if !(every_s.is_finite() && every_s > 0.0) {
        return Err(InspectError::Inconsistent {
            path: name,
            message: format!(
                "the pose rate must be a positive number of seconds, got {every_s} (e.g. every_s=1.0)"
            ),
        });
    }
    let mut reader = LogReader::open(path).map_err(ReplayError::from)?;
    let config = header_config(&reader, &name)?;
    let seed = reader.header().seed;
    let mut world = State::genesis(&config, seed)
        .map_err(|source| ReplayError::Start {
            path: name.clone(),
            cause: source,
        })?
        .world;
    let step_ms = ((every_s * 1000.0).round() as u64).max(1);
    let (mut time, mut robot) = (Vec::new(), Vec::new());
    let (mut xs, mut ys, mut thetas) = (Vec::new(), Vec::new(), Vec::new());
    let mut next = 0u64;
    loop {
        if world.time().0 >= next {
            for (r, p) in world.poses().iter().enumerate() {
                time.push(world.time().secs());
                robot.push(r as u64);
                xs.push(p.x);
                ys.push(p.y);
                thetas.push(p.theta);
            }
            next = (world.time().0 / step_ms + 1) * step_ms;
        }
        let record = match reader.next_record().map_err(ReplayError::from)? {
            Some(r) => r,
            None => break,
        };
        if let Record::Event {
            time: at,
            event: Event::Tick(tick),
        } = &record
        {
            let index = reader.index() - 1;
            crate::state::apply_tick(&mut world, *at, tick).map_err(|source| {
                ReplayError::Apply {
                    path: name.clone(),
                    index,
                    kind: "tick",
                    time: *at,
                    cause: source,
                }
            })?;
        }
    }
    let mut t = Table::default();
    t.push("time_s", Column::F64(time));
    t.push("robot", Column::U64(robot));
    t.push("x", Column::F64(xs));
    t.push("y", Column::F64(ys));
    t.push("theta", Column::F64(thetas));
    Ok(t)
}

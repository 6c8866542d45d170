//! Inspect and bisect a baseline run by time: it has no blocks, so its points are its
//! checkpoints (one every `ledger.block_period_s`, and the end).
//!
//! The predicate language is `inspect`'s ([`Expr`]); a baseline defines
//! `time` (s), `round` (aggregations so far: honest robots' merges from a quorum, or server
//! rounds), `loss` (the paper's metric of the last aggregation, NaN before) and `heldout_loss`
//! (the mean over honest robots of their current models' held-out loss; `central`: the
//! server's model). Identifiers about tokens or blocks are errors that say why.

use std::path::Path;
use std::sync::Arc;

use serde::Serialize;

use super::bisect::first_holding;
use super::error::InspectError;
use super::expr::{Env, EvalError, Expr};
use crate::byzantine;
use crate::config::{Aggregation, Config};
use crate::event::Record;
use crate::learn::{self, ModelShape, TrainData};
use crate::log::LogReader;
use crate::metrics::Metrics;
use crate::replay::{self, ReplayError};
use crate::state::State;
use crate::types::{RobotId, SimTime};

/// The state of a baseline run at one checkpoint, reduced to what `inspect` shows.
#[derive(Clone, Debug, Serialize)]
pub struct TimeReport {
    /// The checkpoint's time, simulated s.
    pub time_s: f64,
    /// The aggregation.
    pub aggregation: Aggregation,
    /// Aggregations so far (honest merges from a quorum, or server rounds).
    pub round: u64,
    /// Paper metric of the last aggregation (NaN before).
    pub loss: f64,
    /// Mean held-out loss over honest robots' current models.
    pub heldout_loss: f64,
    /// Per robot.
    pub robots: Vec<RobotTime>,
}

/// One robot at a checkpoint.
#[derive(Clone, Debug, Serialize)]
pub struct RobotTime {
    /// Its id.
    pub robot: RobotId,
    /// Whether it is Byzantine.
    pub byzantine: bool,
    /// `gossip`: the keys it holds and their versions; `central`: empty.
    pub entries: Vec<(RobotId, u64)>,
    /// Bytes it sent so far.
    pub bytes_sent: u64,
    /// Held-out loss of the model it would start from now.
    pub heldout_loss: f64,
}

/// The values of one checkpoint for predicates (the models are kept, losses computed lazily).
struct Point {
    time: SimTime,
    round: u64,
    loss: f64,
    models: Vec<Arc<[i64]>>,
}

struct Ctx {
    config: Config,
    shape: ModelShape,
    heldout: Option<TrainData>,
    byzantine: Vec<bool>,
}

impl Ctx {
    fn heldout_loss(&self, weights: &[i64]) -> f64 {
        match &self.heldout {
            Some(d) => learn::loss(
                &self.shape,
                &learn::from_fixed(weights, self.config.contract.weight_scale),
                d,
            ),
            None => f64::NAN,
        }
    }

    fn mean_heldout(&self, models: &[Arc<[i64]>]) -> f64 {
        let losses: Vec<f64> = models
            .iter()
            .zip(&self.byzantine)
            .filter(|(_, &b)| !b)
            .map(|(m, _)| self.heldout_loss(m))
            .collect();
        if losses.is_empty() {
            f64::NAN
        } else {
            losses.iter().sum::<f64>() / losses.len() as f64
        }
    }
}

fn last_loss(state: &State, metrics: &Metrics, byzantine: &[bool]) -> (u64, f64) {
    let honest: Vec<_> = state
        .aggregation
        .aggregations
        .iter()
        .filter(|a| a.robot.is_none_or(|r| !byzantine[r as usize]))
        .collect();
    let loss = honest.last().map_or(f64::NAN, |a| {
        let (mut w, mut n) = (0.0, 0.0);
        for h in &a.models {
            if let Some(t) = metrics.trained.get(h).filter(|t| t.val_loss.is_finite()) {
                w += f64::from(t.train_samples) * t.val_loss;
                n += f64::from(t.train_samples);
            }
        }
        if n > 0.0 {
            w / n
        } else {
            f64::NAN
        }
    });
    (honest.len() as u64, loss)
}

fn open(
    path: &Path,
) -> Result<(LogReader<std::io::BufReader<std::fs::File>>, Config, u64), InspectError> {
    let name = path.display().to_string();
    let reader = LogReader::open(path).map_err(ReplayError::from)?;
    let config = replay::header_config(&reader, &name)?;
    if config.learn.aggregation == Aggregation::Chain {
        return Err(InspectError::Inconsistent {
            path: name,
            message: "this is a chain run: inspect it by block (--block H)".to_string(),
        });
    }
    let seed = reader.header().seed;
    Ok((reader, config, seed))
}

fn context(config: &Config, seed: u64, state: &State) -> Ctx {
    let shape = ModelShape::from_config(config);
    let heldout = TrainData::new(&shape, state.world.heldout())
        .ok()
        .filter(|d| !d.is_empty());
    Ctx {
        config: config.clone(),
        shape,
        heldout,
        byzantine: byzantine::byzantine_robots(config, seed),
    }
}

/// The state of the baseline run at `path` at the last checkpoint at or before `time` (folding
/// and verifying the records up to it).
pub fn report_at(path: &Path, time: SimTime) -> Result<TimeReport, InspectError> {
    let (state, config, seed) = replay::state_at_time(path, time)?;
    if config.learn.aggregation == Aggregation::Chain {
        return Err(InspectError::Inconsistent {
            path: path.display().to_string(),
            message: "this is a chain run: inspect it by block (--block H)".to_string(),
        });
    }
    let ctx = context(&config, seed, &state);
    let a = &state.aggregation;
    let models = a.models();
    let (round, loss) = last_loss(&state, &state.metrics, &ctx.byzantine);
    let robots = (0..config.world.robots)
        .map(|r| RobotTime {
            robot: r,
            byzantine: ctx.byzantine[r as usize],
            entries: a
                .stigmergy
                .held(r)
                .iter()
                .map(|e| (e.id.key, e.id.clock))
                .collect(),
            bytes_sent: a.bytes_sent[r as usize],
            heldout_loss: ctx.heldout_loss(&a.preview(r).weights),
        })
        .collect();
    Ok(TimeReport {
        time_s: state.world.time().secs(),
        aggregation: config.learn.aggregation,
        round,
        loss,
        heldout_loss: ctx.mean_heldout(&models),
        robots,
    })
}

/// A checkpoint where a predicate holds: its time (s) and the leaf values that made it true.
pub type TimeHit = (f64, Vec<(String, f64)>);

/// The first checkpoint of the baseline run at `path` where `predicate` holds: its time and
/// the leaf values that made it true, and the number of evaluations. `monotone` declares the
/// predicate false then true for good (binary search over the checkpoints).
pub fn bisect_by_time(
    path: &Path,
    predicate: &Expr,
    monotone: bool,
) -> Result<(Option<TimeHit>, u64), InspectError> {
    let name = path.display().to_string();
    let (mut reader, config, seed) = open(path)?;
    let mut state = State::genesis(&config, seed).map_err(|source| {
        InspectError::Replay(ReplayError::Start {
            path: name.clone(),
            cause: source,
        })
    })?;
    let ctx = context(&config, seed, &state);
    let mut points = Vec::new();
    while let Some(record) = reader.next_record().map_err(ReplayError::from)? {
        let index = reader.index() - 1;
        replay::fold_record(&mut state, &name, index, &record)?;
        if let Record::Checkpoint(c) = &record {
            let (round, loss) = last_loss(&state, &state.metrics, &ctx.byzantine);
            points.push(Point {
                time: c.time,
                round,
                loss,
                models: state.aggregation.models(),
            });
        }
    }
    let mut evaluations = 0u64;
    let mut holds = |i: usize| -> Result<bool, InspectError> {
        evaluations += 1;
        predicate
            .holds(&PointEnv {
                point: &points[i],
                ctx: &ctx,
            })
            .map_err(|source| InspectError::Eval {
                block: i as u64,
                cause: source,
            })
    };
    if points.is_empty() {
        return Ok((None, 0));
    }
    let found = first_holding(points.len() as u64 - 1, monotone, |i| holds(i as usize))?
        .map(|i| i as usize);
    Ok((
        found.map(|i| {
            let env = PointEnv {
                point: &points[i],
                ctx: &ctx,
            };
            (points[i].time.secs(), predicate.leaves(&env))
        }),
        evaluations,
    ))
}

struct PointEnv<'a> {
    point: &'a Point,
    ctx: &'a Ctx,
}

impl Env for PointEnv<'_> {
    fn ident(&self, name: &str) -> Result<f64, EvalError> {
        match name {
            "time" => Ok(self.point.time.secs()),
            "round" => Ok(self.point.round as f64),
            "loss" => Ok(self.point.loss),
            "heldout_loss" => Ok(self.ctx.mean_heldout(&self.point.models)),
            other => Err(EvalError(format!(
                "`{other}` is not defined for a {} run (no blocks, no tokens): use time, \
                 round, loss or heldout_loss",
                self.ctx.config.learn.aggregation.name()
            ))),
        }
    }

    fn indexed(&self, name: &str, _index: u32) -> Result<f64, EvalError> {
        Err(EvalError(format!(
            "`{name}[i]` is not defined for a baseline run (no tokens)"
        )))
    }

    fn node(&self, _index: u32, _field: &str) -> Result<f64, EvalError> {
        Err(EvalError(
            "`node[i]` is not defined for a baseline run (no ledger)".to_string(),
        ))
    }
}

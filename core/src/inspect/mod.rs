//! Looking into a finished run at any block of its final canonical chain: the block index,
//! the state at a block (`swarmfl inspect`), per-block values for predicates (`swarmfl bisect`)
//! and the tables of `swarmfl export`.
//!
//! # How a block is reached
//!
//! The *final canonical chain* is the canonical chain of [`crate::metrics::best_node`] at the end
//! of the log; block `H` is its block at height `H`. Which block that is is only known at the
//! end, so [`index_run`] folds the whole log once (checking every checkpoint) and, on the way:
//! - for every sealed block, remembers the index of its sealing checkpoint, its time and every
//!   node's head height at that moment (the sealing node's head *is* the new block at its
//!   checkpoint: a node always seals on its own head);
//! - for the one height asked for (if any), clones the full [`State`] at the checkpoint of each
//!   block sealed at that height (one per competing fork, usually one), and keeps the clone of
//!   the block that turns out canonical.
//!
//! So `inspect` costs one fold of the log plus one `State` clone per block sealed at the asked
//! height. The contract state after *every* block needs no fold at all: every
//! [`crate::ledger::BlockEntry`] of the final ledger carries it, which is what `bisect` and
//! `export` read (node head heights come from the index).
//!
//! # Sidecar index instead of snapshots (measured)
//!
//! The final canonical chain (which block *is* height H) is only known at the end of the log,
//! so a first lookup needs the whole fold; `swarmfl inspect` then writes the sidecar index `LOG.idx` ([`Sidecar`]:
//! the final canonical chain with every block's sealing-checkpoint record index, tied to the log
//! by its size and footer); later lookups ([`block_report_indexed`]) fold only up to the block.
//!
//! On the 5000 s `paper` log (85 102 records, 677 sealed blocks, 495 canonical, 15 robots),
//! release build, on a shared and busy 2-core machine: `swarmfl replay` 0.60 s;
//! `inspect --block H` without the index 0.55 to 0.97 s for any H (whole fold + report), with
//! the index 6 ms (H = 0), 0.2 s (H = 100), 0.4 s (H = 300), 0.7 s (H = 495);
//! `bisect` 0.52 to 0.7 s (the whole fold, then microseconds of evaluation; `heldout_loss` adds
//! about 1 ms per distinct round evaluated); `export` 0.86 s.
//!
//! Full-state snapshots every K blocks would bound the fold to K blocks' worth of records, but
//! need serde for `Ledger` and `World` (not derived today: the ledger shares blocks and
//! transactions through `Arc`s, the world holds its random streams) and `LogReader` seeking to
//! a byte offset. At this scale the fold is below the 1 s target, so they are not written.

//! The predicate language of `bisect` is in [`expr`] (grammar in its module docs).

pub mod expr;

#[cfg(test)]
mod tests;

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::byzantine;
use crate::config::Config;
use crate::contract::{Call, ContractState, Outcome, Verdict};
use crate::event::{CheckpointCause, Event, Record};
use crate::learn::{self, ModelShape, TrainData};
use crate::ledger::BlockHash;
use crate::log::LogReader;
use crate::metrics::{self, LearnReport};
use crate::replay::{self, header_config, ReplayError};
use crate::sim::State;
use crate::types::{Digest, RobotId, SimTime};

pub use expr::{EvalError, Expr, ParseError};

/// Why a look into a run failed.
#[derive(Debug, thiserror::Error)]
pub enum InspectError {
    /// The log cannot be read or folded.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// The block asked for is beyond the final canonical chain.
    #[error("{path}: there is no block {block} on the final canonical chain; its last block is at height {last}")]
    BlockPastEnd {
        /// The log.
        path: String,
        /// The height asked for.
        block: u64,
        /// The last height.
        last: u64,
    },
    /// The robot asked for is not in the swarm.
    #[error("there is no robot {robot}: the swarm has robots 0..{robots}")]
    NoRobot {
        /// The id asked for.
        robot: RobotId,
        /// The swarm size.
        robots: u32,
    },
    /// The log's blocks do not fit together (a damaged or foreign log).
    #[error("{path}: {message}")]
    Inconsistent {
        /// The log.
        path: String,
        /// What does not fit.
        message: String,
    },
    /// A predicate names a value the state does not have.
    #[error("cannot evaluate the expression at block {block}: {source}")]
    Eval {
        /// The block.
        block: u64,
        /// What is wrong.
        source: EvalError,
    },
}

/// Folds one record into `state` (events) or checks it (checkpoints).
fn fold_record(
    state: &mut State,
    learned: &mut LastLearning,
    name: &str,
    index: u64,
    record: &Record,
) -> Result<(), InspectError> {
    fold_record_checked(state, learned, name, index, record, true)
}

/// [`fold_record`], checking a checkpoint only when `check` is set.
fn fold_record_checked(
    state: &mut State,
    learned: &mut LastLearning,
    name: &str,
    index: u64,
    record: &Record,
    check: bool,
) -> Result<(), InspectError> {
    if check || matches!(record, Record::Event { .. }) {
        replay::fold_record(state, name, index, record)?;
    }
    if let Record::Event { time, event } = record {
        note_learning(learned, *time, event);
    }
    Ok(())
}

/// Keeps a robot's last learning report.
fn note_learning(learned: &mut LastLearning, time: SimTime, event: &Event) {
    if let Event::Learn(report) = event {
        if let Some(slot) = learned.get_mut(report.robot as usize) {
            *slot = Some((time, report.clone()));
        }
    }
}

/// Ticks handed to the world's thread at a time.
const TICK_BATCH: usize = 256;

/// Folds the records of `reader` up to and including record `stop`, checking only the
/// checkpoint at `stop` (see [`block_report_indexed`]), and returns that record's time. The
/// world's reducer runs on a second thread: ticks touch only the world and every other event
/// never reads it, so the two halves of the state are folded side by side and meet at `stop`
/// and at reconfigurations (folded with the whole state). Same result as a sequential fold.
fn fold_to_record(
    reader: &mut LogReader<std::io::BufReader<std::fs::File>>,
    state: &mut State,
    learned: &mut LastLearning,
    config: &mut Config,
    name: &str,
    stop: u64,
) -> Result<SimTime, InspectError> {
    type TickBatch = Vec<(u64, SimTime, crate::world::TickEvent)>;
    loop {
        let meet: (u64, Record) = std::thread::scope(|scope| {
            let State {
                world,
                ledger,
                metrics,
                ..
            } = &mut *state;
            let (to_world, from_reader) = std::sync::mpsc::sync_channel::<TickBatch>(8);
            let worker = scope.spawn(move || {
                for batch in from_reader {
                    for (index, time, tick) in batch {
                        crate::sim::apply_tick(world, time, &tick)
                            .map_err(|source| (index, time, source))?;
                    }
                }
                Ok::<(), (u64, SimTime, crate::sim::ApplyError)>(())
            });
            let mut batch: TickBatch = Vec::with_capacity(TICK_BATCH);
            // `None`: the world's thread stopped (on an error, reported after the join).
            let mut read = || -> Result<Option<(u64, Record)>, InspectError> {
                loop {
                    let Some(record) = reader.next_record().map_err(ReplayError::from)? else {
                        return Err(InspectError::Inconsistent {
                            path: name.to_string(),
                            message: format!(
                                "the log ends before record {stop} named by its index"
                            ),
                        });
                    };
                    let index = reader.index() - 1;
                    if index == stop {
                        return Ok(Some((index, record)));
                    }
                    match record {
                        Record::Event {
                            time,
                            event: Event::Tick(tick),
                        } => {
                            batch.push((index, time, tick));
                            if batch.len() == TICK_BATCH
                                && to_world.send(std::mem::take(&mut batch)).is_err()
                            {
                                return Ok(None);
                            }
                        }
                        Record::Event {
                            time,
                            event: ref event @ (Event::Ledger(_) | Event::Learn(_)),
                        } => {
                            crate::sim::apply_ledger_side(ledger, metrics, time, event).map_err(
                                |source| ReplayError::Apply {
                                    path: name.to_string(),
                                    index,
                                    kind: event.kind(),
                                    time,
                                    source,
                                },
                            )?;
                            note_learning(learned, time, event);
                        }
                        Record::Checkpoint(_) => {}
                        other => return Ok(Some((index, other))),
                    }
                }
            };
            let result = read();
            if !batch.is_empty() {
                let _ = to_world.send(batch);
            }
            drop(to_world);
            // A failed tick comes before anything the reader failed on: report it first.
            if let Err((index, time, source)) =
                worker.join().expect("the world's fold never panics")
            {
                return Err(InspectError::Replay(ReplayError::Apply {
                    path: name.to_string(),
                    index,
                    kind: "tick",
                    time,
                    source,
                }));
            }
            Ok(result?.expect("the world's thread stops only on an error"))
        })?;
        let (index, record) = meet;
        fold_record_checked(state, learned, name, index, &record, index == stop)?;
        if let Some(next) = replay::reconfigured(&record) {
            *config = next;
        }
        if index == stop {
            return Ok(record.time());
        }
    }
}

/// The sidecar index of a log (`LOG.idx`, JSON): its final canonical chain with the record
/// index of every block's sealing checkpoint, tied to the log by its size and the digest of its
/// last 64 bytes (the footer, which holds the log's final hash). With it, `inspect` folds the
/// log only up to the block instead of to the end.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct Sidecar {
    /// Sidecar format version ([`SIDECAR_VERSION`]).
    pub version: u32,
    /// Size of the log in bytes.
    pub log_bytes: u64,
    /// blake3 of the log's last 64 bytes, hex.
    pub tail: String,
    /// The final canonical chain: (height, block id, sealing checkpoint record; none for genesis).
    pub blocks: Vec<(u64, Digest, Option<u64>)>,
}

/// Version of the [`Sidecar`] format.
pub const SIDECAR_VERSION: u32 = 1;

/// `LOG.idx` next to `LOG`.
pub fn sidecar_path(log: &Path) -> std::path::PathBuf {
    let mut name = log.as_os_str().to_os_string();
    name.push(".idx");
    std::path::PathBuf::from(name)
}

fn log_identity(path: &Path) -> Result<(u64, String), InspectError> {
    use std::io::{Read, Seek, SeekFrom};
    let io = |e: std::io::Error| {
        InspectError::Replay(ReplayError::Log(crate::log::LogError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        }))
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    file.seek(SeekFrom::Start(len.saturating_sub(64)))
        .map_err(io)?;
    let mut tail = Vec::new();
    file.read_to_end(&mut tail).map_err(io)?;
    Ok((len, blake3::hash(&tail).to_hex().to_string()))
}

impl RunIndex {
    /// The sidecar index of this run.
    pub fn sidecar(&self, log: &Path) -> Result<Sidecar, InspectError> {
        let (log_bytes, tail) = log_identity(log)?;
        Ok(Sidecar {
            version: SIDECAR_VERSION,
            log_bytes,
            tail,
            blocks: self
                .chain
                .iter()
                .map(|r| (r.height, r.hash, r.record))
                .collect(),
        })
    }
}

/// Reads `LOG.idx` if it exists and belongs to this very log; `None` otherwise (absent, stale,
/// another version or unreadable: the caller then folds the whole log and rewrites it).
pub fn read_sidecar(log: &Path) -> Option<Sidecar> {
    let text = std::fs::read_to_string(sidecar_path(log)).ok()?;
    let sidecar: Sidecar = serde_json::from_str(&text).ok()?;
    let (log_bytes, tail) = log_identity(log).ok()?;
    let fits = sidecar.version == SIDECAR_VERSION
        && sidecar.log_bytes == log_bytes
        && sidecar.tail == tail
        && !sidecar.blocks.is_empty()
        && sidecar
            .blocks
            .iter()
            .enumerate()
            .all(|(i, b)| b.0 == i as u64 && (i == 0) == b.2.is_none());
    fits.then_some(sidecar)
}

/// The report of block `height` using a sidecar index: folds the log only up to the block's
/// sealing checkpoint.
pub fn block_report_indexed(
    log: &Path,
    sidecar: &Sidecar,
    height: u64,
    robot: Option<RobotId>,
) -> Result<BlockReport, InspectError> {
    let name = log.display().to_string();
    let last = sidecar.blocks.len() as u64 - 1;
    if height > last {
        return Err(InspectError::BlockPastEnd {
            path: name,
            block: height,
            last,
        });
    }
    let mut reader = LogReader::open(log).map_err(ReplayError::from)?;
    let mut config = header_config(&reader, &name)?;
    let seed = reader.header().seed;
    let mut state = State::genesis(&config, seed).map_err(|source| ReplayError::Start {
        path: name.clone(),
        source,
    })?;
    let mut learned: LastLearning = vec![None; config.world.robots as usize];
    let (_, hash, record) = sidecar.blocks[height as usize];
    // The sidecar was written by a fold that checked every checkpoint of this very log (tied
    // to it by size and footer digest), and the hash chain guarantees the records are the
    // same: only the block's own checkpoint is checked again.
    let time = match record {
        Some(stop) => fold_to_record(
            &mut reader,
            &mut state,
            &mut learned,
            &mut config,
            &name,
            stop,
        )?,
        None => SimTime(0),
    };
    let canonical = sidecar.blocks.iter().map(|b| b.1).collect();
    let row = BlockRow {
        height,
        hash,
        time,
        record,
        node_heights: Vec::new(),
    };
    report_at(
        &ReportInput {
            path: &name,
            config: &config,
            byzantine: &byzantine::byzantine_robots(&config, seed),
            canonical: &canonical,
            row: &row,
            state: &state,
            learned: &learned,
        },
        robot,
    )
}

/// One block of the final canonical chain, as seen while folding.
#[derive(Clone, Debug)]
pub struct BlockRow {
    /// Height (genesis is 0).
    pub height: u64,
    /// The block id.
    pub hash: BlockHash,
    /// Its timestamp.
    pub time: SimTime,
    /// Index of its sealing checkpoint record (`None` for genesis: before every record).
    pub record: Option<u64>,
    /// Every node's head height right after it was sealed.
    pub node_heights: Vec<u64>,
}

/// One point of the per-node chain sizes (taken at every sealing checkpoint).
#[derive(Clone, Debug)]
pub struct ChainBytesRow {
    /// Simulated time.
    pub time: SimTime,
    /// Each node's canonical chain size in bytes.
    pub bytes: Vec<u64>,
}

/// What one fold of a log knows about its final canonical chain.
pub struct RunIndex {
    /// The log's name.
    pub path: String,
    /// The run's configuration.
    pub config: Config,
    /// The run's seed.
    pub seed: u64,
    /// Which robots are Byzantine.
    pub byzantine: Vec<bool>,
    /// The final canonical chain, by height (row 0 is genesis).
    pub chain: Vec<BlockRow>,
    /// The state at the end of the log.
    pub final_state: State,
    /// Records in the log.
    pub records: u64,
    /// Chain sizes per node, at every sealing.
    pub chain_bytes: Vec<ChainBytesRow>,
    /// `Some(why)` when the log is truncated: everything here is of its intact prefix (the
    /// records before the cut), and `final_state` is the state after the last intact record.
    pub truncated: Option<String>,
    /// The state right after the sealing of the block asked for in [`index_run`], with each
    /// robot's last learning report until then.
    pub at_block: Option<StateAtBlock>,
}

/// Each robot's last learning report so far, with its time.
pub type LastLearning = Vec<Option<(SimTime, LearnReport)>>;

/// The full state right after a block's sealing, with each robot's last learning report.
pub type StateAtBlock = (State, LastLearning);

struct Sealed {
    record: u64,
    time: SimTime,
    node_heights: Vec<u64>,
}

/// Folds the whole log at `path` (checking every checkpoint) and indexes its final canonical
/// chain; with `want = Some(h)`, also keeps the full state right after block `h` was sealed
/// (an error names the last height if the chain is shorter).
///
/// A truncated log is indexed as far as its intact prefix goes, with
/// [`RunIndex::truncated`] saying why; a corrupt (altered) one is refused.
pub fn index_run(path: &Path, want: Option<u64>) -> Result<RunIndex, InspectError> {
    let name = path.display().to_string();
    let mut reader = LogReader::open(path).map_err(ReplayError::from)?;
    let mut config = header_config(&reader, &name)?;
    let seed = reader.header().seed;
    let mut state = State::genesis(&config, seed).map_err(|source| ReplayError::Start {
        path: name.clone(),
        source,
    })?;
    let robots = config.world.robots;
    let mut sealed: BTreeMap<BlockHash, Sealed> = BTreeMap::new();
    let mut chain_bytes = Vec::new();
    let mut learned: LastLearning = vec![None; robots as usize];
    let mut candidates: BTreeMap<BlockHash, StateAtBlock> = BTreeMap::new();
    let genesis_state = (want == Some(0)).then(|| (state.clone(), learned.clone()));
    let mut truncated = None;
    loop {
        let record = match reader.next_record() {
            Ok(Some(record)) => record,
            Ok(None) => break,
            // A log cut short (a killed run, a full disk, a partial copy): every record before
            // the cut is intact (the hash chain verifies it), so the run is indexed as far as
            // it got and the caller says so. An altered record is still refused.
            Err(e @ crate::log::LogError::Truncated { .. }) => {
                truncated = Some(e.to_string());
                break;
            }
            Err(e) => return Err(ReplayError::from(e).into()),
        };
        let index = reader.index() - 1;
        fold_record(&mut state, &mut learned, &name, index, &record)?;
        if let Some(next) = replay::reconfigured(&record) {
            config = next;
        }
        if let Record::Checkpoint(expected) = &record {
            if let CheckpointCause::Block { node, height } = expected.cause {
                if node >= robots {
                    return Err(inconsistent(&name, index, "names a node out of the swarm"));
                }
                let (hash, head_height) = state.ledger.head(node);
                if head_height != height {
                    return Err(inconsistent(
                            &name,
                            index,
                            &format!("says node {node} sealed height {height}, but its head is at {head_height}"),
                        ));
                }
                let node_heights: Vec<u64> = (0..robots).map(|r| state.ledger.head(r).1).collect();
                chain_bytes.push(ChainBytesRow {
                    time: expected.time,
                    bytes: (0..robots)
                        .map(|r| {
                            let head = state.ledger.head(r).0;
                            state.ledger.block(&head).map_or(0, |e| e.chain_bytes)
                        })
                        .collect(),
                });
                sealed.insert(
                    hash,
                    Sealed {
                        record: index,
                        time: expected.time,
                        node_heights,
                    },
                );
                if want == Some(height) {
                    candidates.insert(hash, (state.clone(), learned.clone()));
                }
            }
        }
    }
    let records = match reader.footer() {
        Some(footer) => footer.records,
        None => reader.index(),
    };
    let best = metrics::best_node(&state.ledger);
    let mut chain = Vec::new();
    for (height, hash) in state.ledger.canonical_chain(best).iter().enumerate() {
        let entry = state
            .ledger
            .block(hash)
            .ok_or_else(|| InspectError::Inconsistent {
                path: name.clone(),
                message: format!("canonical block {} is not stored", hash.short()),
            })?;
        let row = if height == 0 {
            BlockRow {
                height: 0,
                hash: *hash,
                time: SimTime(0),
                record: None,
                node_heights: vec![0; robots as usize],
            }
        } else {
            if truncated.is_some() && !sealed.contains_key(hash) {
                // The cut fell between a block's sealing and its checkpoint: the chain of the
                // intact prefix ends at its parent.
                break;
            }
            let s = sealed.get(hash).ok_or_else(|| InspectError::Inconsistent {
                path: name.clone(),
                message: format!(
                    "canonical block {} at height {height} has no sealing checkpoint",
                    hash.short()
                ),
            })?;
            BlockRow {
                height: height as u64,
                hash: *hash,
                time: s.time,
                record: Some(s.record),
                node_heights: s.node_heights.clone(),
            }
        };
        assert_eq!(
            entry.block.header.height, row.height,
            "heights follow the chain"
        );
        chain.push(row);
    }
    let last = chain.len() as u64 - 1;
    let at_block = match want {
        None => None,
        Some(h) if h > last => {
            return Err(InspectError::BlockPastEnd {
                path: name,
                block: h,
                last,
            })
        }
        Some(0) => genesis_state,
        Some(h) => Some(
            candidates
                .remove(&chain[h as usize].hash)
                .expect("every block sealed at the height asked for was kept"),
        ),
    };
    Ok(RunIndex {
        path: name,
        byzantine: byzantine::byzantine_robots(&config, seed),
        config,
        seed,
        chain,
        final_state: state,
        records,
        chain_bytes,
        at_block,
        truncated,
    })
}

fn inconsistent(path: &str, index: u64, what: &str) -> InspectError {
    InspectError::Inconsistent {
        path: path.to_string(),
        message: format!("the block checkpoint at record {index} {what}"),
    }
}

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
    /// The last height of the final canonical chain.
    pub fn last_height(&self) -> u64 {
        self.chain.len() as u64 - 1
    }

    /// The contract state right after block `height` of the final canonical chain.
    pub fn contract_at(&self, height: u64) -> &ContractState {
        let row = &self.chain[height as usize];
        &self
            .final_state
            .ledger
            .block(&row.hash)
            .expect("canonical blocks are stored")
            .state
    }

    /// The rounds closed on the final canonical chain, in order.
    pub fn rounds(&self) -> Vec<RoundRow> {
        let ledger = &self.final_state.ledger;
        let trained = &self.final_state.metrics.trained;
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
                    let (mut weighted, mut samples) = (0.0f64, 0.0f64);
                    for tx in &round_txs {
                        if let Some(r) = trained.get(tx) {
                            if r.val_loss.is_finite() {
                                weighted += f64::from(r.train_samples) * r.val_loss;
                                samples += f64::from(r.train_samples);
                            }
                        }
                    }
                    round_txs.clear();
                    let summary = entry.state.last_round.as_ref();
                    let count = |v: Verdict| {
                        summary.map_or(0, |s| {
                            s.submissions.iter().filter(|x| x.verdict == v).count() as u64
                        })
                    };
                    let per_weight = ledger.params().model_len() as f64
                        * self.config.contract.weight_scale as f64;
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
                                .map(|x| x.distance_units as f64 / per_weight)
                                .collect()
                        })
                        .unwrap_or_default();
                    let mean_honest_distance = if honest.is_empty() {
                        f64::NAN
                    } else {
                        honest.iter().sum::<f64>() / honest.len() as f64
                    };
                    out.push(RoundRow {
                        mean_honest_distance,
                        // The contract counts model versions from 0: the round that closes
                        // version v into v + 1 is round v + 1.
                        round: *round + 1,
                        block: row.height,
                        time_s: row.time.secs(),
                        loss: if samples > 0.0 {
                            weighted / samples
                        } else {
                            f64::NAN
                        },
                        accepted: count(Verdict::Accepted),
                        outliers: count(Verdict::Outlier),
                    });
                }
            }
        }
        out
    }

    /// The values of every block of the final canonical chain, for predicates.
    pub fn values(&self) -> ChainValues<'_> {
        let rounds = self.rounds();
        let mut loss_at = Vec::with_capacity(self.chain.len());
        let mut next = 0;
        let mut loss = f64::NAN;
        for row in &self.chain {
            while next < rounds.len() && rounds[next].block <= row.height {
                loss = rounds[next].loss;
                next += 1;
            }
            loss_at.push(loss);
        }
        ChainValues {
            index: self,
            loss_at,
            shape: ModelShape::from_config(&self.config),
            heldout: TrainData::new(
                &ModelShape::from_config(&self.config),
                self.final_state.world.heldout(),
            )
            .ok()
            .filter(|d| !d.is_empty()),
            heldout_cache: RefCell::new(BTreeMap::new()),
        }
    }

    /// Tokens of `units`.
    pub fn tokens(&self, units: u64) -> f64 {
        units as f64 / self.config.contract.token_units as f64
    }
}

/// Per-block values of the final canonical chain (see [`expr::IDENTS`]).
pub struct ChainValues<'a> {
    index: &'a RunIndex,
    loss_at: Vec<f64>,
    shape: ModelShape,
    heldout: Option<TrainData>,
    heldout_cache: RefCell<BTreeMap<u64, f64>>,
}

impl ChainValues<'_> {
    /// The values at block `height` (an [`expr::Env`]).
    pub fn at(&self, height: u64) -> BlockValues<'_> {
        assert!(height <= self.index.last_height(), "height on the chain");
        BlockValues {
            values: self,
            height,
        }
    }

    /// Number of blocks (genesis included).
    pub fn len(&self) -> usize {
        self.index.chain.len()
    }

    /// Never true: a chain has its genesis.
    pub fn is_empty(&self) -> bool {
        self.index.chain.is_empty()
    }
}

/// The values at one block: an [`expr::Env`].
pub struct BlockValues<'a> {
    values: &'a ChainValues<'a>,
    height: u64,
}

impl expr::Env for BlockValues<'_> {
    fn ident(&self, name: &str) -> Result<f64, EvalError> {
        let index = self.values.index;
        let row = &index.chain[self.height as usize];
        let state = index.contract_at(self.height);
        let group = |byz: bool| -> (f64, usize) {
            let units: Vec<u64> = state
                .balances
                .iter()
                .zip(&index.byzantine)
                .filter(|(_, &b)| b == byz)
                .map(|(&u, _)| u)
                .collect();
            (index.tokens(units.iter().sum()), units.len())
        };
        let mean = |(sum, n): (f64, usize)| if n == 0 { f64::NAN } else { sum / n as f64 };
        // Balance plus the stakes the group has in the current round (still in the pool).
        let wealth = |byz: bool| -> f64 {
            let staked: u64 = state
                .submissions
                .iter()
                .filter(|s| index.byzantine.get(s.sender as usize) == Some(&byz))
                .map(|s| s.stake_units)
                .sum();
            let (sum, n) = group(byz);
            if n == 0 {
                f64::NAN
            } else {
                (sum + index.tokens(staked)) / n as f64
            }
        };
        Ok(match name {
            "height" => row.height as f64,
            "time" => row.time.secs(),
            "round" => state.round as f64,
            "loss" => self.values.loss_at[self.height as usize],
            "heldout_loss" => {
                let mut cache = self.values.heldout_cache.borrow_mut();
                *cache
                    .entry(state.round)
                    .or_insert_with(|| match &self.values.heldout {
                        Some(data) => learn::loss(
                            &self.values.shape,
                            &learn::from_fixed(&state.weights, index.config.contract.weight_scale),
                            data,
                        ),
                        None => f64::NAN,
                    })
            }
            "byzantine_tokens" => mean(group(true)),
            "honest_tokens" => mean(group(false)),
            "byzantine_wealth" => wealth(true),
            "honest_wealth" => wealth(false),
            "byzantine_sum" => group(true).0,
            "honest_sum" => group(false).0,
            "byzantine_share" => crate::metrics::byzantine_share(&state.balances, &index.byzantine),
            "accepted" => state.accepted_count() as f64,
            "outliers" => state
                .submissions
                .iter()
                .filter(|s| s.verdict == Verdict::Outlier)
                .count() as f64,
            "pool" => index.tokens(state.holdings_units),
            "robots" => index.config.world.robots as f64,
            other => return Err(EvalError(format!("unknown identifier `{other}`"))),
        })
    }

    fn indexed(&self, name: &str, i: u32) -> Result<f64, EvalError> {
        let index = self.values.index;
        let state = index.contract_at(self.height);
        match name {
            "balance" => state
                .balances
                .get(i as usize)
                .map(|&u| index.tokens(u))
                .ok_or_else(|| no_robot(name, i, index.config.world.robots)),
            other => Err(EvalError(format!("`{other}` cannot be indexed"))),
        }
    }

    fn node(&self, i: u32, field: &str) -> Result<f64, EvalError> {
        let index = self.values.index;
        let row = &index.chain[self.height as usize];
        match field {
            "height" => row
                .node_heights
                .get(i as usize)
                .map(|&h| h as f64)
                .ok_or_else(|| no_robot("node", i, index.config.world.robots)),
            other => Err(EvalError(format!("node[{i}] has no field `{other}`"))),
        }
    }
}

fn no_robot(name: &str, i: u32, robots: u32) -> EvalError {
    EvalError(format!(
        "{name}[{i}]: there is no robot {i}, the swarm has robots 0..{robots}"
    ))
}

/// The first block of the final canonical chain where `predicate` holds.
#[derive(Clone, Debug, Serialize)]
pub struct BisectHit {
    /// Its height.
    pub height: u64,
    /// Its timestamp, s.
    pub time_s: f64,
    /// The values the predicate read there.
    pub values: Vec<(String, f64)>,
    /// Predicate evaluations done.
    pub evaluations: u64,
}

/// Finds the first block where `predicate` holds: a scan from genesis, or with `monotone`
/// a binary search (which assumes that once it holds, it holds at every later block; it then
/// evaluates O(log n) blocks). `None` when it holds nowhere (for `monotone`: not at the last
/// block).
pub fn bisect(
    values: &ChainValues<'_>,
    predicate: &Expr,
    monotone: bool,
) -> Result<Option<BisectHit>, InspectError> {
    let mut evaluations = 0u64;
    let mut holds = |h: u64| -> Result<bool, InspectError> {
        evaluations += 1;
        predicate
            .holds(&values.at(h))
            .map_err(|source| InspectError::Eval { block: h, source })
    };
    let found = first_holding(values.len() as u64 - 1, monotone, &mut holds)?;
    Ok(found.map(|h| {
        let env = values.at(h);
        BisectHit {
            height: h,
            time_s: values.index.chain[h as usize].time.secs(),
            values: predicate.leaves(&env),
            evaluations,
        }
    }))
}

/// The first point in `0..=last` where `holds` is true, or None. With `monotone` (the
/// predicate, once true, stays true) a binary search that evaluates it about log2(last) + 1
/// times; otherwise a scan from 0. Evaluation errors stop the search.
pub(crate) fn first_holding<E>(
    last: u64,
    monotone: bool,
    mut holds: impl FnMut(u64) -> Result<bool, E>,
) -> Result<Option<u64>, E> {
    if !monotone {
        for i in 0..=last {
            if holds(i)? {
                return Ok(Some(i));
            }
        }
        return Ok(None);
    }
    if !holds(last)? {
        return Ok(None);
    }
    // Invariant: the predicate holds at `hi`; it does not hold below `lo`.
    let (mut lo, mut hi) = (0u64, last);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if holds(mid)? {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    Ok(Some(hi))
}

/// How a predicate behaves over the whole final canonical chain.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Profile {
    /// The first block where it holds.
    pub first: Option<u64>,
    /// The first block from which it holds at every later block ("for good").
    pub for_good_from: Option<u64>,
    /// Whether it is monotone (false, then true for good).
    pub monotone: bool,
    /// How many times it turns from true to false.
    pub relapses: u64,
}

/// Evaluates `predicate` at every block (cheap: the values are in memory once the log is
/// folded) to tell whether a `--monotone` answer can be trusted.
pub fn profile(values: &ChainValues<'_>, predicate: &Expr) -> Result<Profile, InspectError> {
    let mut truth = Vec::with_capacity(values.len());
    for h in 0..values.len() as u64 {
        truth.push(
            predicate
                .holds(&values.at(h))
                .map_err(|source| InspectError::Eval { block: h, source })?,
        );
    }
    let first = truth.iter().position(|&t| t).map(|h| h as u64);
    let for_good_from = match truth.iter().rposition(|&t| !t) {
        None => Some(0),
        Some(last_false) if last_false + 1 < truth.len() => Some(last_false as u64 + 1),
        Some(_) => None,
    };
    let relapses = truth.windows(2).filter(|w| w[0] && !w[1]).count() as u64;
    Ok(Profile {
        first,
        for_good_from,
        monotone: relapses == 0,
        relapses,
    })
}

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
    /// Index of its sealing checkpoint record.
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
    /// Distance to the shared model, fixed-point units.
    pub distance_units: u64,
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
    report_at(
        &ReportInput {
            path: &index.path,
            config: &index.config,
            byzantine: &index.byzantine,
            canonical: &canonical,
            row: &index.chain[height as usize],
            state,
            learned,
        },
        robot,
    )
}

/// Everything a block report is made from.
struct ReportInput<'a> {
    path: &'a str,
    config: &'a Config,
    byzantine: &'a [bool],
    canonical: &'a std::collections::BTreeSet<BlockHash>,
    row: &'a BlockRow,
    state: &'a State,
    learned: &'a LastLearning,
}

fn report_at(input: &ReportInput<'_>, robot: Option<RobotId>) -> Result<BlockReport, InspectError> {
    let ReportInput {
        path,
        config,
        byzantine,
        canonical,
        row,
        state,
        learned,
    } = *input;
    let robots = config.world.robots;
    if let Some(r) = robot {
        if r >= robots {
            return Err(InspectError::NoRobot { robot: r, robots });
        }
    }
    let height = row.height;
    let tokens = |units: u64| units as f64 / config.contract.token_units as f64;
    // The block was sealed by then, so the state's own ledger has it and its transactions.
    let final_ledger = &state.ledger;
    let entry = final_ledger
        .block(&row.hash)
        .ok_or_else(|| InspectError::Inconsistent {
            path: path.to_string(),
            message: format!("block {} is not known at its sealing", row.hash.short()),
        })?;
    let header = &entry.block.header;
    let byz = |r: RobotId| byzantine.get(r as usize).copied().unwrap_or(false);
    let txs = entry
        .block
        .txs
        .iter()
        .zip(entry.receipts.iter())
        .map(|(h, outcome)| {
            let tx = final_ledger.tx(h).map(|t| t.tx.clone());
            let (sender, value, call) = match tx.as_deref() {
                Some(t) => (
                    t.sender,
                    t.value_units,
                    match &t.call {
                        Call::SubmitModel { samples, .. } => format!("submit(n={samples})"),
                        Call::Transfer { to, amount_units } => {
                            format!("transfer(to={to}, {} tokens)", tokens(*amount_units))
                        }
                    },
                ),
                None => (RobotId::MAX, 0, "?".to_string()),
            };
            TxInfo {
                hash: h.to_hex(),
                sender,
                byzantine: byz(sender),
                call,
                value_tokens: tokens(value),
                outcome: outcome.name().to_string(),
                detail: outcome_detail(outcome),
            }
        })
        .collect();
    let submission = |s: &crate::contract::Submission| SubmissionInfo {
        sender: s.sender,
        byzantine: byz(s.sender),
        samples: s.samples,
        distance_units: s.distance_units,
        stake_tokens: tokens(s.stake_units),
        verdict: match s.verdict {
            Verdict::Accepted => "accepted",
            Verdict::Outlier => "outlier",
        }
        .to_string(),
    };
    let cs = &entry.state;
    let contract = ContractInfo {
        round: cs.round,
        model_digest: cs.weights_digest.to_hex(),
        balances: cs
            .balances
            .iter()
            .enumerate()
            .map(|(r, &u)| BalanceInfo {
                robot: r as RobotId,
                tokens: tokens(u),
                byzantine: byz(r as RobotId),
            })
            .collect(),
        pool_tokens: tokens(cs.holdings_units),
        submissions: cs.submissions.iter().map(submission).collect(),
        last_round: cs.last_round.as_ref().map(|s| RoundInfo {
            round: s.round + 1,
            submissions: s.submissions.iter().map(submission).collect(),
            pool_tokens: tokens(s.pool_units),
            carried_tokens: tokens(s.carried_units),
            payouts: s
                .payouts
                .iter()
                .map(|p| (p.robot, p.rank, p.reward_weight, tokens(p.units)))
                .collect(),
        }),
    };
    let node_info = |r: RobotId| {
        let (head, h) = state.ledger.head(r);
        NodeInfo {
            node: r,
            head: head.to_hex(),
            height: h,
            on_final_chain: canonical.contains(&head),
        }
    };
    let robot_info = |r: RobotId| {
        let pose = state.world.poses()[r as usize];
        RobotInfo {
            robot: r,
            byzantine: byz(r),
            x: pose.x,
            y: pose.y,
            theta: pose.theta,
            peers: state.world.peers(r).len(),
            dataset: state.world.dataset_len(r),
        }
    };
    let view = robot.map(|r| {
        let own = state.ledger.head_state(r);
        RobotView {
            robot: r,
            byzantine: byz(r),
            node: node_info(r),
            round: own.round,
            balance_tokens: tokens(own.balances[r as usize]),
            world: robot_info(r),
            peers: state.world.peers(r).to_vec(),
            last_learning: learned[r as usize]
                .as_ref()
                .map(|(t, report)| (t.secs(), describe_learning(report))),
        }
    });
    Ok(BlockReport {
        log: path.to_string(),
        block: BlockInfo {
            height,
            hash: row.hash.to_hex(),
            parent: header.parent.to_hex(),
            time_s: row.time.secs(),
            signer: (height > 0).then_some(header.signer),
            difficulty: header.difficulty,
            total_difficulty: entry.total_difficulty,
            chain_bytes: entry.chain_bytes,
            record: row.record,
            txs,
        },
        contract,
        nodes: (0..robots).map(node_info).collect(),
        world: WorldInfo {
            time_s: state.world.time().secs(),
            robots: (0..robots).map(robot_info).collect(),
        },
        robot: view,
    })
}

fn outcome_detail(outcome: &Outcome) -> String {
    match outcome {
        Outcome::Accepted {
            round,
            distance_units,
        } => format!("round {}, distance {distance_units}", round + 1),
        Outcome::Aggregated {
            round,
            distance_units,
            payouts,
        } => format!(
            "closed round {}, distance {distance_units}, {} payouts",
            round + 1,
            payouts.len()
        ),
        Outcome::Outlier {
            round,
            distance_units,
        } => format!("round {}, distance {distance_units}", round + 1),
        Outcome::Malformed(reason) => reason.clone(),
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

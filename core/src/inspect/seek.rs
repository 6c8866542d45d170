//! Block lookups on one log that keep full-state snapshots in memory
//! (`output.snapshot_every_blocks`): a later lookup starts from the nearest snapshot at or
//! before its block instead of folding the log from genesis.
//!
//! A [`Seeker`] holds the log's final canonical chain (its [`Sidecar`]: the record of every
//! block's sealing checkpoint) and, for every `output.snapshot_every_blocks`-th block of that
//! chain that a lookup has folded past, the reduced state right after its sealing, each robot's
//! last learning report, the configuration in force and the reader's [`Position`] there. The
//! snapshots live only as long as the seeker: nothing is written, and the log's records are the
//! same for every value of the key. Looking up blocks in order costs one fold of the log in all
//! instead of one fold per block (the Python package's `Run.at(block=...)` keeps a seeker per
//! log; `swarmfl inspect --block` uses one for its single lookup).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::at_block::{BlockReport, ReportInput};
use super::error::InspectError;
use super::fold::{fold_to_record, LastLearning};
use super::index::{index_run, BlockRow};
use super::sidecar::{log_identity, read_sidecar, Sidecar};
use crate::byzantine;
use crate::config::Config;
use crate::log::{LogReader, Position};
use crate::replay::{header_config, ReplayError};
use crate::state::State;
use crate::types::{RobotId, SimTime};

/// Most snapshots a seeker keeps (the first ones met; a run with more blocks than this many
/// times the key's value keeps only the early ones).
pub const MAX_SNAPSHOTS: usize = 64;

/// The state right after one block's sealing, and where the log's reader stands there.
#[derive(Clone)]
struct Snapshot {
    state: State,
    learned: LastLearning,
    config: Config,
    position: Position,
    time: SimTime,
}

/// Block lookups on one log, keeping a snapshot every `output.snapshot_every_blocks` blocks of
/// its final canonical chain (see the module documentation).
pub struct Seeker {
    log: PathBuf,
    name: String,
    sidecar: Sidecar,
    /// The header's `output.snapshot_every_blocks` (0: no snapshot).
    every: u64,
    /// By the record index of the block's sealing checkpoint.
    snapshots: BTreeMap<u64, Snapshot>,
    /// Records the last lookup folded.
    folded: u64,
}

impl Seeker {
    /// A seeker of `log`, whose final canonical chain `sidecar` holds (it must be this log's:
    /// [`read_sidecar`], or [`super::RunIndex::sidecar`] of a fold of it).
    pub fn new(log: &Path, sidecar: Sidecar) -> Result<Seeker, InspectError> {
        let name = log.display().to_string();
        let reader = LogReader::open(log).map_err(ReplayError::from)?;
        let config = header_config(&reader, &name)?;
        Ok(Seeker {
            log: log.to_path_buf(),
            name,
            sidecar,
            every: u64::from(config.output.snapshot_every_blocks),
            snapshots: BTreeMap::new(),
            folded: 0,
        })
    }

    /// A seeker of `log`: its sidecar index `LOG.idx` if one fits it, else one fold of the
    /// whole log to find its final canonical chain (a cut log: that of its intact prefix).
    pub fn open(log: &Path) -> Result<Seeker, InspectError> {
        let sidecar = match read_sidecar(log) {
            Some(sidecar) => sidecar,
            None => index_run(log, None)?.sidecar(log)?,
        };
        Seeker::new(log, sidecar)
    }

    /// Height of the final canonical chain.
    pub fn last_height(&self) -> u64 {
        self.sidecar.blocks.len() as u64 - 1
    }

    /// Snapshots kept so far.
    pub fn snapshots(&self) -> usize {
        self.snapshots.len()
    }

    /// Records the last lookup folded (from its starting snapshot, or from genesis).
    pub fn last_folded(&self) -> u64 {
        self.folded
    }

    /// The report of block `height` (with `robot`'s view when asked for): folds from the
    /// nearest snapshot at or before the block (or from genesis) up to its sealing checkpoint,
    /// keeping a snapshot at every `output.snapshot_every_blocks`-th block on the way. A log
    /// that changed since the seeker read its chain is read again (its snapshots dropped).
    pub fn block_report(
        &mut self,
        height: u64,
        robot: Option<RobotId>,
    ) -> Result<BlockReport, InspectError> {
        let (bytes, tail) = log_identity(&self.log)?;
        if (bytes, tail.as_str()) != (self.sidecar.log_bytes, self.sidecar.tail.as_str()) {
            *self = Seeker::open(&self.log)?;
        }
        let last = self.last_height();
        if height > last {
            return Err(InspectError::BlockPastEnd {
                path: self.name.clone(),
                block: height,
                last,
            });
        }
        let (_, hash, record) = self.sidecar.blocks[height as usize];
        let mut reader = LogReader::open(&self.log).map_err(ReplayError::from)?;
        let seed = reader.header().seed;
        let start = record.and_then(|stop| self.snapshots.range(..=stop).next_back());
        let (mut at, mut now) = match start {
            Some((&index, snapshot)) => {
                reader
                    .seek_to(&snapshot.position)
                    .map_err(ReplayError::from)?;
                (Some(index), snapshot.clone())
            }
            None => {
                let config = header_config(&reader, &self.name)?;
                let state = State::genesis(&config, seed).map_err(|source| ReplayError::Start {
                    path: self.name.clone(),
                    cause: source,
                })?;
                let learned = vec![None; config.world.robots as usize];
                let position = reader.position();
                (
                    None,
                    Snapshot {
                        state,
                        learned,
                        config,
                        position,
                        time: SimTime(0),
                    },
                )
            }
        };
        self.folded = 0;
        if let Some(stop) = record {
            // The blocks to keep a snapshot of on the way, then the block itself. The sidecar
            // was written by a fold that checked every checkpoint of this very log, and the
            // hash chain guarantees the records are the same: only the checkpoints stopped at
            // are checked again.
            let marks: Vec<u64> = self.marks(at, stop);
            for to in marks.into_iter().chain([stop]) {
                if at.is_some_and(|a| a >= to) {
                    continue;
                }
                now.time = fold_to_record(
                    &mut reader,
                    &mut now.state,
                    &mut now.learned,
                    &mut now.config,
                    &self.name,
                    to,
                )?;
                self.folded += to - at.map_or(0, |a| a + 1) + 1;
                at = Some(to);
                if to != stop || self.is_mark(height) {
                    self.keep(to, &now, &reader);
                }
            }
        }
        let canonical = self.sidecar.blocks.iter().map(|b| b.1).collect();
        let row = BlockRow {
            height,
            hash,
            time: now.time,
            record,
            node_heights: Vec::new(),
        };
        ReportInput {
            path: &self.name,
            config: &now.config,
            byzantine: &byzantine::byzantine_robots(&now.config, seed),
            canonical: &canonical,
            row: &row,
            state: &now.state,
            learned: &now.learned,
        }
        .report(robot)
    }

    /// Whether block `height` gets a snapshot.
    fn is_mark(&self, height: u64) -> bool {
        self.every > 0 && height > 0 && height.is_multiple_of(self.every)
    }

    /// The sealing records of the blocks to keep a snapshot of after record `after` and before
    /// record `stop`.
    fn marks(&self, after: Option<u64>, stop: u64) -> Vec<u64> {
        if self.every == 0 {
            return Vec::new();
        }
        self.sidecar
            .blocks
            .iter()
            .filter(|(height, _, _)| self.is_mark(*height))
            .filter_map(|b| b.2)
            .filter(|&r| after.is_none_or(|a| r > a) && r < stop)
            .collect()
    }

    /// Keeps the state after record `index` (a block's sealing checkpoint), while there is
    /// room.
    fn keep(&mut self, index: u64, now: &Snapshot, reader: &LogReader<impl std::io::Read>) {
        if self.snapshots.len() < MAX_SNAPSHOTS && !self.snapshots.contains_key(&index) {
            let mut snapshot = now.clone();
            snapshot.position = reader.position();
            self.snapshots.insert(index, snapshot);
        }
    }
}

/// The report of block `height` using a sidecar index: folds the log only up to the block's
/// sealing checkpoint (a [`Seeker`] for one lookup).
pub fn block_report_indexed(
    log: &Path,
    sidecar: &Sidecar,
    height: u64,
    robot: Option<RobotId>,
) -> Result<BlockReport, InspectError> {
    Seeker::new(log, sidecar.clone())?.block_report(height, robot)
}

//! The block index of a log: one fold (checking every checkpoint) that finds the final
//! canonical chain, each block's sealing record, time and node heights ([`index_run`]); the
//! same fold fed one record at a time ([`Indexer`]) for a log that is still growing.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use super::error::InspectError;
use super::fold::{fold_record, LastLearning};
use crate::byzantine;
use crate::config::Config;
use crate::contract::{ContractState, RoundSummary};
use crate::event::{CheckpointCause, Event, Record};
use crate::ledger::{BlockHash, LedgerEvent, WireItem};
use crate::log::LogReader;
use crate::metrics;
use crate::replay::{self, header_config, ReplayError};
use crate::state::State;
use crate::types::{RobotId, SimTime};

/// One block of the final canonical chain, as seen while folding.
#[derive(Clone, Debug)]
pub struct BlockRow {
    /// Height (genesis is 0).
    pub height: u64,
    /// The block id.
    pub hash: BlockHash,
    /// Its timestamp.
    pub time: SimTime,
    /// Index of its sealing checkpoint record (`None` for genesis: before every record); for a
    /// block that came from outside the honest gossip with no sealing checkpoint of its own
    /// (an equivocator's twin), of the [`LedgerEvent::Inject`] record that stored it.
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

/// The full state right after a block's sealing, with each robot's last learning report.
pub type StateAtBlock = (State, LastLearning);

/// A block's sealing, as seen while folding.
struct Sealed {
    record: u64,
    time: SimTime,
    node_heights: Vec<u64>,
}

/// What the fold notes at block checkpoints.
struct Sealings {
    /// The swarm size.
    robots: u32,
    /// The height whose state is kept ([`index_run`]'s `want`).
    want: Option<u64>,
    /// Every sealed block.
    sealed: BTreeMap<BlockHash, Sealed>,
    /// The state after each block sealed at height `want` (one per competing fork).
    candidates: BTreeMap<BlockHash, StateAtBlock>,
}

impl Sealings {
    /// Notes the sealing of `height` by `node` that the checkpoint at record `index` (time
    /// `time`) announces, after checking that the node's head is that block; returns the
    /// chain sizes at that sealing.
    fn note(
        &mut self,
        state: &State,
        learned: &LastLearning,
        name: &str,
        index: u64,
        time: SimTime,
        (node, height): (RobotId, u64),
    ) -> Result<ChainBytesRow, InspectError> {
        let robots = self.robots;
        if node >= robots {
            return Err(inconsistent(name, index, "names a node out of the swarm"));
        }
        let (hash, head_height) = state.ledger.head(node);
        if head_height != height {
            return Err(inconsistent(
                name,
                index,
                &format!(
                    "says node {node} sealed height {height}, but its head is at {head_height}"
                ),
            ));
        }
        let node_heights: Vec<u64> = (0..robots).map(|r| state.ledger.head(r).1).collect();
        let sizes = ChainBytesRow {
            time,
            bytes: (0..robots)
                .map(|r| {
                    let head = state.ledger.head(r).0;
                    state.ledger.block(&head).map_or(0, |e| e.chain_bytes)
                })
                .collect(),
        };
        self.sealed.insert(
            hash,
            Sealed {
                record: index,
                time,
                node_heights,
            },
        );
        if self.want == Some(height) {
            self.candidates
                .insert(hash, (state.clone(), learned.clone()));
        }
        Ok(sizes)
    }

    /// Notes a block that the injection at record `index` (time `time`) stored, if `bytes`
    /// encode one that no sealing announced: an equivocator seals one block of a pair (its
    /// checkpoint names the node's head) and injects the twin to other peers, and either may
    /// end up canonical. The ledger stores an injected block at once or refuses it (an
    /// unknown parent is a refusal, not a wait), so the record that stored it is this one.
    fn note_injected(
        &mut self,
        state: &State,
        learned: &LastLearning,
        index: u64,
        time: SimTime,
        bytes: &[u8],
    ) {
        // Undecodable or foreign items are the ledger's to refuse; only stored blocks matter.
        let Ok(WireItem::Block(wire)) = rmp_serde::from_slice::<WireItem>(bytes) else {
            return;
        };
        let (hash, _) = wire.header.hash_and_size();
        if self.sealed.contains_key(&hash) || state.ledger.block(&hash).is_none() {
            return;
        }
        let node_heights = (0..self.robots).map(|r| state.ledger.head(r).1).collect();
        self.sealed.insert(
            hash,
            Sealed {
                record: index,
                time,
                node_heights,
            },
        );
        if self.want == Some(wire.header.height) {
            self.candidates
                .insert(hash, (state.clone(), learned.clone()));
        }
    }
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
    let mut indexer = Indexer::start(&reader, &name, want)?;
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
        indexer.feed(reader.index() - 1, &record)?;
    }
    indexer.finish(truncated)
}

/// The fold of [`index_run`], fed one record at a time: a log that is still growing (the live
/// view) is indexed as far as it has been read, and indexed again after more records, each
/// record folded once. [`Indexer::index`] gives the index of the records so far at any point.
pub struct Indexer {
    /// The index of the records fed so far; its `chain`, `byzantine`, `truncated` and
    /// `at_block` are brought up to date by [`Indexer::index`], the rest by every record.
    index: RunIndex,
    seen: Sealings,
    learned: LastLearning,
    genesis_state: Option<StateAtBlock>,
}

impl Indexer {
    /// An index of no record yet of the log that `reader` opened (`name` names it in errors);
    /// `want` as in [`index_run`].
    pub fn start<R: Read>(
        reader: &LogReader<R>,
        name: &str,
        want: Option<u64>,
    ) -> Result<Indexer, InspectError> {
        let config = header_config(reader, name)?;
        Indexer::for_config(config, reader.header().seed, name, want)
    }

    /// An index of no record yet of a run of `config` with `seed` that is not read from a
    /// log (a simulation folded as it runs: `swarmfl blame`'s counterfactuals); `name` names
    /// it in errors, `want` as in [`index_run`].
    pub fn for_config(
        config: Config,
        seed: u64,
        name: &str,
        want: Option<u64>,
    ) -> Result<Indexer, InspectError> {
        let state = State::genesis(&config, seed).map_err(|source| ReplayError::Start {
            path: name.to_string(),
            cause: source,
        })?;
        let robots = config.world.robots;
        let learned: LastLearning = vec![None; robots as usize];
        let genesis_state = (want == Some(0)).then(|| (state.clone(), learned.clone()));
        Ok(Indexer {
            index: RunIndex {
                path: name.to_string(),
                byzantine: Vec::new(),
                config,
                seed,
                chain: Vec::new(),
                final_state: state,
                records: 0,
                chain_bytes: Vec::new(),
                truncated: None,
                at_block: None,
            },
            seen: Sealings {
                robots,
                want,
                sealed: BTreeMap::new(),
                candidates: BTreeMap::new(),
            },
            learned,
            genesis_state,
        })
    }

    /// Folds the record at `index` (the next one: records are fed in order, each once).
    pub fn feed(&mut self, index: u64, record: &Record) -> Result<(), InspectError> {
        assert_eq!(index, self.index.records, "records are fed in order");
        let run = &mut self.index;
        let (state, name) = (&mut run.final_state, &run.path);
        fold_record(state, &mut self.learned, name, index, record)?;
        run.records = index + 1;
        if let Some(next) = replay::reconfigured(record) {
            run.config = next;
        }
        if let Record::Event {
            time,
            event: Event::Ledger(LedgerEvent::Inject { bytes, .. }),
        } = record
        {
            self.seen
                .note_injected(&run.final_state, &self.learned, index, *time, bytes);
        }
        if let Record::Checkpoint(expected) = record {
            if let CheckpointCause::Block { node, height } = expected.cause {
                let row = self.seen.note(
                    &run.final_state,
                    &self.learned,
                    &run.path,
                    index,
                    expected.time,
                    (node, height),
                )?;
                run.chain_bytes.push(row);
            }
        }
        Ok(())
    }

    /// The state after the records fed so far.
    pub fn state(&self) -> &State {
        &self.index.final_state
    }

    /// The run's configuration after the records fed so far (reconfigurations applied).
    pub fn config(&self) -> &Config {
        &self.index.config
    }

    /// Records fed so far.
    pub fn records(&self) -> u64 {
        self.index.records
    }

    /// The index of the records fed so far, as [`index_run`] makes it of a log that holds just
    /// those records; `truncated` says why the log ends there if it has no footer yet. Costs
    /// the length of the canonical chain (and, with `want`, a copy of that block's state).
    pub fn index(&mut self, truncated: Option<String>) -> Result<&RunIndex, InspectError> {
        let at_block = self.chain_and_block(truncated.is_some(), |seen, hash| {
            seen.candidates.get(hash).cloned()
        })?;
        self.index.at_block = at_block;
        self.index.truncated = truncated;
        Ok(&self.index)
    }

    /// The index of every record fed ([`Indexer::index`] without copying anything).
    pub fn finish(mut self, truncated: Option<String>) -> Result<RunIndex, InspectError> {
        let at_block = self.chain_and_block(truncated.is_some(), |seen, hash| {
            seen.candidates.remove(hash)
        })?;
        self.index.at_block = at_block;
        self.index.truncated = truncated;
        Ok(self.index)
    }

    /// Brings the chain and the Byzantine robots up to date and takes the state at the block
    /// asked for with `take`.
    fn chain_and_block(
        &mut self,
        truncated: bool,
        take: impl FnOnce(&mut Sealings, &BlockHash) -> Option<StateAtBlock>,
    ) -> Result<Option<StateAtBlock>, InspectError> {
        let run = &mut self.index;
        run.chain = final_chain(&run.final_state, &self.seen, truncated, &run.path)?;
        run.byzantine = byzantine::byzantine_robots(&run.config, run.seed);
        let last = run.chain.len() as u64 - 1;
        Ok(match self.seen.want {
            None => None,
            Some(h) if h > last => {
                return Err(InspectError::BlockPastEnd {
                    path: run.path.clone(),
                    block: h,
                    last,
                })
            }
            Some(0) => self.genesis_state.clone(),
            Some(h) => Some(
                take(&mut self.seen, &run.chain[h as usize].hash)
                    .expect("every block sealed at the height asked for was kept"),
            ),
        })
    }
}

/// The rows of the final canonical chain (the best node's at the end of the fold) from the
/// sealings seen; with `truncated`, it ends at the last block whose checkpoint is in the log.
fn final_chain(
    state: &State,
    seen: &Sealings,
    truncated: bool,
    name: &str,
) -> Result<Vec<BlockRow>, InspectError> {
    let best = metrics::best_node(&state.ledger);
    let mut chain = Vec::new();
    for (height, hash) in state.ledger.canonical_chain(best).iter().enumerate() {
        let entry = state
            .ledger
            .block(hash)
            .ok_or_else(|| InspectError::Inconsistent {
                path: name.to_string(),
                message: format!("canonical block {} is not stored", hash.short()),
            })?;
        let row = if height == 0 {
            BlockRow {
                height: 0,
                hash: *hash,
                time: SimTime(0),
                record: None,
                node_heights: vec![0; seen.robots as usize],
            }
        } else {
            if truncated && !seen.sealed.contains_key(hash) {
                // The cut fell between a block's sealing and its checkpoint: the chain of the
                // intact prefix ends at its parent.
                break;
            }
            let s = seen
                .sealed
                .get(hash)
                .ok_or_else(|| InspectError::Inconsistent {
                    path: name.to_string(),
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
    Ok(chain)
}

fn inconsistent(path: &str, index: u64, what: &str) -> InspectError {
    InspectError::Inconsistent {
        path: path.to_string(),
        message: format!("the block checkpoint at record {index} {what}"),
    }
}

impl RunIndex {
    /// The last height of the final canonical chain.
    pub fn last_height(&self) -> u64 {
        self.chain.len() as u64 - 1
    }

    /// Every round that closed on the final canonical chain, oldest first: the height of the
    /// block that closed it and the contract's summary of it. Each round comes once, though
    /// every block after the closing one carries the same summary until the next close.
    pub fn closed_rounds(&self) -> Vec<(u64, &RoundSummary)> {
        let mut out = Vec::new();
        let mut last = None;
        for row in &self.chain {
            let Some(summary) = self.contract_at(row.height).last_round.as_deref() else {
                continue;
            };
            if last == Some(summary.round) {
                continue;
            }
            last = Some(summary.round);
            out.push((row.height, summary));
        }
        out
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

    /// Tokens of `units`.
    pub fn tokens(&self, units: u64) -> f64 {
        units as f64 / self.config.contract.token_units as f64
    }
}

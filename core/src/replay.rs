//! Replaying a log: folding its events through the reducers and checking every checkpoint, or
//! re-simulating the run from its header and comparing record by record.

use std::io::Read;
use std::path::Path;

use crate::byzantine::plugin::Plugins;
use crate::config::{Config, ConfigError};
use crate::event::{Event, Record};
use crate::log::{encode_record, Footer, LogError, LogReader};
use crate::sim::Sim;
use crate::state::{apply_tick, ApplyError, SimError, State};
use crate::types::{Digest, SimTime};
use crate::world::World;

/// Why a replay failed.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The log itself is unreadable, cut or damaged.
    #[error(transparent)]
    Log(#[from] LogError),
    /// The header's configuration is not valid for this build.
    #[error("{path}: the configuration in the log header is not valid for this swarmfl: {cause}")]
    Config {
        /// The log.
        path: String,
        /// What is wrong.
        cause: ConfigError,
    },
    /// A plug-in the header records is not given, or its source changed
    /// (`byzantine::plugin`).
    #[error("{path}: {message}")]
    Plugin {
        /// The log.
        path: String,
        /// Which plug-in, and what is wrong.
        message: String,
    },
    /// The run cannot start from the header's configuration.
    #[error("{path}: cannot start the run of the header: {cause}")]
    Start {
        /// The log.
        path: String,
        /// What is wrong.
        cause: SimError,
    },
    /// An event does not fit the state.
    #[error("{path}: record {index} ({kind} at t = {time}) cannot be applied: {cause}")]
    Apply {
        /// The log.
        path: String,
        /// Record index.
        index: u64,
        /// Record kind.
        kind: &'static str,
        /// Simulated time.
        time: SimTime,
        /// What is wrong.
        cause: ApplyError,
    },
    /// The replayed or re-simulated run differs from the log.
    #[error(
        "{path}: diverged at record {index} ({kind} at t = {time}): {component} differs{detail}"
    )]
    Diverged {
        /// The log.
        path: String,
        /// Index of the first diverging record.
        index: u64,
        /// Kind of the log's record there.
        kind: &'static str,
        /// Its simulated time.
        time: SimTime,
        /// Which component (or record) differs.
        component: String,
        /// More detail (what the other side had).
        detail: String,
    },
}

/// The result of a successful replay.
#[derive(Debug)]
pub struct ReplayReport {
    /// Records checked.
    pub records: u64,
    /// Checkpoints verified.
    pub checkpoints: u64,
    /// Checkpoints taken at a sealed block.
    pub blocks: u64,
    /// The log's final hash.
    pub final_hash: Digest,
    /// The state rebuilt at the end.
    pub state: State,
    /// The configuration of the run at its end (after any reconfiguration).
    pub config: Config,
}

/// The configuration recorded in a log's header.
pub fn header_config<R: Read>(reader: &LogReader<R>, path: &str) -> Result<Config, ReplayError> {
    crate::config::parse_config(&reader.header().config_toml, &format!("{path} (header)")).map_err(
        |source| ReplayError::Config {
            path: path.to_string(),
            cause: source,
        },
    )
}

/// The configuration a record switches to, if it is a reconfiguration the reducers accepted.
pub fn reconfigured(record: &Record) -> Option<Config> {
    match record {
        Record::Event {
            event: Event::Reconfigure(change),
            ..
        } => crate::config::parse_config(&change.config_toml, "the reconfiguration").ok(),
        _ => None,
    }
}

/// Folds one record of the log at `name` into `state`: an event through the reducers, a
/// checkpoint compared with the state's digests. `index` is the record's index in the log.
pub fn fold_record(
    state: &mut State,
    name: &str,
    index: u64,
    record: &Record,
) -> Result<(), ReplayError> {
    match record {
        Record::Event { time, event } => {
            state
                .apply(*time, event)
                .map_err(|source| ReplayError::Apply {
                    path: name.to_string(),
                    index,
                    kind: record.kind(),
                    time: *time,
                    cause: source,
                })
        }
        Record::Checkpoint(expected) => match state
            .checkpoint(expected.time, expected.cause)
            .first_difference(expected)
        {
            None => Ok(()),
            Some(component) => Err(ReplayError::Diverged {
                path: name.to_string(),
                index,
                kind: record.kind(),
                time: expected.time,
                component,
                detail: " between the log's checkpoint and the replayed state".to_string(),
            }),
        },
    }
}

/// Folds every event of the log at `path` through the reducers and checks every checkpoint.
pub fn replay(path: &Path) -> Result<ReplayReport, ReplayError> {
    let name = path.display().to_string();
    let mut reader = LogReader::open(path)?;
    let config = header_config(&reader, &name)?;
    let seed = reader.header().seed;
    let mut state = State::genesis(&config, seed).map_err(|source| ReplayError::Start {
        path: name.clone(),
        cause: source,
    })?;
    let (mut checkpoints, mut blocks) = (0u64, 0u64);
    let mut config = config;
    while let Some(record) = reader.next_record()? {
        let index = reader.index() - 1;
        fold_record(&mut state, &name, index, &record)?;
        if let Some(next) = reconfigured(&record) {
            config = next;
        }
        if let Record::Checkpoint(c) = &record {
            checkpoints += 1;
            if matches!(c.cause, crate::event::CheckpointCause::Block { .. }) {
                blocks += 1;
            }
        }
    }
    let Footer {
        records,
        final_hash,
    } = reader.footer().expect("a finished reader has its footer");
    Ok(ReplayReport {
        records,
        checkpoints,
        blocks,
        final_hash,
        state,
        config,
    })
}

/// Re-simulates the run from the header's seed and configuration and compares every record,
/// byte for byte, with the log.
pub fn resimulate(path: &Path) -> Result<ReplayReport, ReplayError> {
    resimulate_with(path, &Plugins::none())
}

/// Checks that the plug-ins the header of the log at `path` records are among `plugins`, with
/// the same sources (what a re-simulation needs): the command (no plug-ins) refuses every log
/// that has one, naming it.
pub fn check_plugins<R: Read>(
    reader: &LogReader<R>,
    path: &str,
    plugins: &Plugins,
) -> Result<(), ReplayError> {
    plugins
        .check(&reader.header().plugins)
        .map_err(|message| ReplayError::Plugin {
            path: path.to_string(),
            message,
        })
}

/// [`check_plugins`] for a fold of the log (`replay` without re-simulation, the viewer, the
/// tables): only a plug-in rule is needed, since every fold re-executes the contract and the
/// rule computes its aggregates; an attack's submissions are records, so a fold runs without
/// the attack.
pub fn check_fold_plugins<R: Read>(
    reader: &LogReader<R>,
    path: &str,
    plugins: &Plugins,
) -> Result<(), ReplayError> {
    let rules: Vec<_> = reader
        .header()
        .plugins
        .iter()
        .filter(|p| p.kind == "rule")
        .cloned()
        .collect();
    plugins
        .check(&rules)
        .map_err(|message| ReplayError::Plugin {
            path: path.to_string(),
            message,
        })
}

/// [`resimulate`] offered `plugins`: the header's plug-ins must be among them, with the same
/// sources ([`check_plugins`]).
pub fn resimulate_with(path: &Path, plugins: &Plugins) -> Result<ReplayReport, ReplayError> {
    let name = path.display().to_string();
    let mut reader = LogReader::open(path)?;
    check_plugins(&reader, &name, plugins)?;
    let config = header_config(&reader, &name)?;
    let seed = reader.header().seed;
    let reconfigurations = reader
        .header()
        .parent
        .as_ref()
        .map(|p| p.reconfigurations.clone())
        .unwrap_or_default();
    let mut sim = Sim::forked_with(config, seed, &reconfigurations, plugins).map_err(|source| {
        ReplayError::Start {
            path: name.clone(),
            cause: source,
        }
    })?;
    let (mut checkpoints, mut blocks) = (0u64, 0u64);
    let mut buf = Vec::new();
    loop {
        let logged = reader.next_record()?;
        let index = reader.index().saturating_sub(1);
        let fresh = sim.next();
        match (logged, fresh) {
            (None, None) => break,
            (Some(logged), None) => {
                return Err(ReplayError::Diverged {
                    path: name,
                    index,
                    kind: logged.kind(),
                    time: logged.time(),
                    component: "record count".to_string(),
                    detail: ": the log has more records than the re-simulation".to_string(),
                })
            }
            (None, Some(fresh)) => {
                return Err(ReplayError::Diverged {
                    path: name,
                    index: reader.index(),
                    kind: fresh.kind(),
                    time: fresh.time(),
                    component: "record count".to_string(),
                    detail: ": the re-simulation has more records than the log".to_string(),
                })
            }
            (Some(logged), Some(fresh)) => {
                encode_record(&fresh, &mut buf);
                if buf != reader.last_payload() {
                    return Err(describe_divergence(&name, index, &logged, &fresh));
                }
                if let Record::Checkpoint(c) = &logged {
                    checkpoints += 1;
                    if matches!(c.cause, crate::event::CheckpointCause::Block { .. }) {
                        blocks += 1;
                    }
                }
            }
        }
    }
    let Footer {
        records,
        final_hash,
    } = reader.footer().expect("a finished reader has its footer");
    let state = sim.state().clone();
    let config = sim.config().clone();
    Ok(ReplayReport {
        records,
        checkpoints,
        blocks,
        final_hash,
        state,
        config,
    })
}

/// Explains how two records at the same index differ.
pub fn describe_divergence(path: &str, index: u64, logged: &Record, fresh: &Record) -> ReplayError {
    let (component, detail) = match (logged, fresh) {
        (Record::Checkpoint(a), Record::Checkpoint(b)) => (
            a.first_difference(b)
                .unwrap_or_else(|| "checkpoint encoding".to_string()),
            " (checkpoint digests differ)".to_string(),
        ),
        (Record::Event { event: a, time: ta }, Record::Event { event: b, time: tb }) => {
            if a.kind() != b.kind() || ta != tb {
                (
                    "event sequence".to_string(),
                    format!(
                        ": the log has {} at t = {ta}, the other run {} at t = {tb}",
                        a.kind(),
                        b.kind()
                    ),
                )
            } else {
                (
                    format!("{} event", a.kind()),
                    ": same kind and time, different contents".to_string(),
                )
            }
        }
        _ => (
            "record sequence".to_string(),
            format!(
                ": the log has a {} record, the other run a {} record",
                logged.kind(),
                fresh.kind()
            ),
        ),
    };
    ReplayError::Diverged {
        path: path.to_string(),
        index,
        kind: logged.kind(),
        time: logged.time(),
        component,
        detail,
    }
}

/// Folds the log at `path` until the world reaches `time` (or the log ends) and returns the
/// state there with the run's configuration and seed. Checkpoints on the way are verified.
pub fn state_at_time(path: &Path, time: SimTime) -> Result<(State, Config, u64), ReplayError> {
    // (Below: `world_at_time`, the same fold of the world alone.)
    let name = path.display().to_string();
    let mut reader = LogReader::open(path)?;
    let config = header_config(&reader, &name)?;
    let seed = reader.header().seed;
    let mut state = State::genesis(&config, seed).map_err(|source| ReplayError::Start {
        path: name.clone(),
        cause: source,
    })?;
    let mut config = config;
    while state.world.time() < time {
        let Some(record) = reader.next_record()? else {
            break;
        };
        fold_record(&mut state, &name, reader.index() - 1, &record)?;
        if let Some(next) = reconfigured(&record) {
            config = next;
        }
    }
    Ok((state, config, seed))
}

/// The world at the first tick at or after `time` (or at the log's end), from the log's tick
/// events alone, every checkpoint's world digest checked: what a picture of the world needs.
/// No ledger or contract is folded, so a log whose contract runs a plug-in rule that is not
/// given (its aggregates are not records) is drawn from its records all the same. Returns the
/// world, the configuration in force there and the seed.
pub fn world_at_time(path: &Path, time: SimTime) -> Result<(World, Config, u64), ReplayError> {
    let name = path.display().to_string();
    let mut reader = LogReader::open(path)?;
    let mut config = header_config(&reader, &name)?;
    let seed = reader.header().seed;
    let mut world = World::new(&config, seed).map_err(|source| ReplayError::Start {
        path: name.clone(),
        cause: SimError::World(source),
    })?;
    while world.time() < time {
        let Some(record) = reader.next_record()? else {
            break;
        };
        let index = reader.index() - 1;
        match &record {
            Record::Event {
                time: at,
                event: Event::Tick(tick),
            } => apply_tick(&mut world, *at, tick).map_err(|cause| ReplayError::Apply {
                path: name.clone(),
                index,
                kind: record.kind(),
                time: *at,
                cause,
            })?,
            Record::Checkpoint(expected) if expected.world != world.digest() => {
                return Err(ReplayError::Diverged {
                    path: name,
                    index,
                    kind: record.kind(),
                    time: expected.time,
                    component: "world".to_string(),
                    detail: " between the log's checkpoint and the replayed world".to_string(),
                })
            }
            _ => {}
        }
        if let Some(next) = reconfigured(&record) {
            config = next;
        }
    }
    Ok((world, config, seed))
}

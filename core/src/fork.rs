//! Forking a run: continuing it from a block of its final canonical chain under a changed
//! configuration.
//!
//! A fork is a run of its own. Its header carries the root configuration and seed of its
//! parent, the parent's final hash, the fork height and the list of reconfigurations (the
//! parent's own, when the parent is itself a fork, then the new one). Its log holds every
//! record: the parent's up to the fork point, re-simulated and checked byte for byte against
//! the parent's log, then an [`Event::Reconfigure`] and a checkpoint, then the continuation.
//! So it replays and re-simulates alone, and `diff PARENT FORK` names the reconfiguration as
//! the first divergence.
//!
//! The fork point of block `H` is the end of the tick in which `H` was sealed (records are
//! decided a tick at a time). From there the agents use the new configuration; the contract's
//! new rules apply to blocks sealed after that time (see [`crate::config::RECONFIGURABLE`]).

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use crate::byzantine::plugin::Plugins;
use crate::config::{Config, ConfigError};
use crate::event::{Event, Reconfiguration, Record};
use crate::inspect::{self, InspectError};
use crate::log::{encode_record, ForkOrigin, Header, LogReader};
use crate::replay::{describe_divergence, header_config, ReplayError};
use crate::types::SimTime;

/// Why a fork cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum ForkError {
    /// A plug-in of the parent is not given or its source changed, or an override names a
    /// plug-in that is not given (`byzantine::plugin`).
    #[error("fork of {path}: {message}")]
    Plugin {
        /// The parent log.
        path: String,
        /// Which plug-in, and what is wrong.
        message: String,
    },
    /// The parent log cannot be read, replayed or indexed (or the block is past its end).
    #[error(transparent)]
    Inspect(#[from] InspectError),
    /// Forking at genesis is a new run.
    #[error("{path}: block 0 is genesis; a fork there is a new run: `swarmfl run --seed {seed} --set KEY=VALUE ...` with the parent's configuration")]
    AtGenesis {
        /// The parent log.
        path: String,
        /// The parent's seed.
        seed: u64,
    },
    /// The parent has no blocks to fork at (a baseline aggregation).
    #[error("{path}: a learn.aggregation = {aggregation} run has no blocks to fork at; forks need learn.aggregation = chain; for a what-if, start a new run: `swarmfl run --seed {seed} --set KEY=VALUE ...` with the parent's configuration")]
    NoBlocks {
        /// The parent log.
        path: String,
        /// Its aggregation.
        aggregation: &'static str,
        /// The parent's seed.
        seed: u64,
    },
    /// An override is malformed or changes a key that cannot change mid-run.
    #[error("fork of {path} at block {height}: {reason}")]
    Override {
        /// The parent log.
        path: String,
        /// The fork height.
        height: u64,
        /// What is wrong.
        reason: ConfigError,
    },
    /// The overrides change nothing.
    #[error("fork of {path} at block {height}: the overrides change nothing; give at least one --set KEY=VALUE that differs from the parent's configuration")]
    NoChange {
        /// The parent log.
        path: String,
        /// The fork height.
        height: u64,
    },
    /// The new configuration ends the run before the fork point.
    #[error("fork of {path} at block {height}: run.duration_s = {duration_s} ends before the fork point at t = {at}; give a longer duration")]
    EndsBeforeFork {
        /// The parent log.
        path: String,
        /// The fork height.
        height: u64,
        /// The new duration.
        duration_s: f64,
        /// The fork point.
        at: SimTime,
    },
    /// The fork point is the parent's last tick: nothing is left to continue.
    #[error("fork of {path} at block {height}: the block is sealed in the run's last tick (t = {at}); to continue it, also set a longer run.duration_s")]
    NothingLeft {
        /// The parent log.
        path: String,
        /// The fork height.
        height: u64,
        /// The fork point.
        at: SimTime,
    },
    /// Re-simulating the parent under this build does not give the parent's records.
    #[error("the parent log does not re-simulate under this build up to the fork point ({divergence}); it was made by swarmfl {crate_version}{commit}: fork it with that build, or re-run the parent with this one")]
    ParentDiverged {
        /// Where and how.
        divergence: Box<ReplayError>,
        /// The parent's crate version.
        crate_version: String,
        /// The parent's commit, when known (" commit abc").
        commit: String,
    },
}

impl From<ReplayError> for ForkError {
    fn from(e: ReplayError) -> ForkError {
        ForkError::Inspect(InspectError::Replay(e))
    }
}

/// Everything needed to write a fork.
#[derive(Clone, Debug)]
pub struct ForkPlan {
    /// The fork's header (root configuration, seed, fork origin).
    pub header: Header,
    /// The root configuration (the parent's header's).
    pub root: Config,
    /// The seed.
    pub seed: u64,
    /// Every reconfiguration, oldest first; the last is the new one.
    pub reconfigurations: Vec<Reconfiguration>,
    /// The configuration from the fork point on.
    pub config: Config,
    /// The keys the fork changes.
    pub changed: Vec<String>,
    /// The fork height.
    pub height: u64,
    /// When block `height` was sealed.
    pub sealed_at: SimTime,
    /// The fork point: the end of that tick.
    pub at: SimTime,
}

/// Plans the fork of the log at `parent` at block `height` of its final canonical chain with
/// the `key=value` `overrides`. Reads the parent's sidecar index when it fits (see
/// [`inspect::read_sidecar`]), otherwise folds the whole parent log once.
pub fn plan(parent: &Path, height: u64, overrides: &[String]) -> Result<ForkPlan, ForkError> {
    plan_with(parent, height, overrides, &Plugins::none())
}

/// [`plan`] offered `plugins`: the parent's plug-ins must be among them with the sources its
/// header records (the error names the plug-in and both digests), and the fork's header records
/// them and any the overrides name.
pub fn plan_with(
    parent: &Path,
    height: u64,
    overrides: &[String],
    plugins: &Plugins,
) -> Result<ForkPlan, ForkError> {
    let name = parent.display().to_string();
    let mut reader = LogReader::open(parent).map_err(ReplayError::from)?;
    let root = header_config(&reader, &name)?;
    let parent_header = reader.header().clone();
    plugins
        .check(&parent_header.plugins)
        .map_err(|message| ForkError::Plugin {
            path: name.clone(),
            message,
        })?;
    let seed = parent_header.seed;
    if height == 0 {
        return Err(ForkError::AtGenesis { path: name, seed });
    }
    if root.learn.aggregation != crate::config::Aggregation::Chain {
        return Err(ForkError::NoBlocks {
            path: name,
            aggregation: root.learn.aggregation.name(),
            seed,
        });
    }
    let record = sealing_record(parent, &name, height)?;
    let sealed_at = record_time(&mut reader, &name, record)?;
    let tick_ms = (root.run.tick_s * 1000.0).round() as u64;
    let at = SimTime(sealed_at.0.div_ceil(tick_ms) * tick_ms);
    let (mut reconfigurations, current) = config_at(&root, &parent_header, at, &name, height)?;
    let (config, changed) = overridden(&current, overrides, &name, height)?;
    let end_ms = current.ticks() * tick_ms;
    if at.0 >= end_ms {
        return Err(ForkError::NothingLeft {
            path: name,
            height,
            at,
        });
    }
    if config.ticks() * tick_ms <= at.0 {
        return Err(ForkError::EndsBeforeFork {
            path: name,
            height,
            duration_s: config.run.duration_s,
            at,
        });
    }
    reconfigurations.push(Reconfiguration {
        at_ms: at.0,
        overrides: overrides.to_vec(),
        config_toml: config.to_toml(),
    });
    while reader.next_record().map_err(ReplayError::from)?.is_some() {}
    let parent_final_hash = reader
        .footer()
        .expect("a finished reader has its footer")
        .final_hash;
    let mut header = Header::new(seed, parent_header.config_toml.clone());
    header.plugins = parent_header.plugins.clone();
    for id in plugins
        .used_by(&config)
        .map_err(|message| ForkError::Plugin {
            path: name.clone(),
            message,
        })?
    {
        if !header.plugins.contains(&id) {
            header.plugins.push(id);
        }
    }
    header.parent = Some(ForkOrigin {
        parent_final_hash,
        height,
        overrides: overrides.to_vec(),
        reconfigurations: reconfigurations.clone(),
    });
    Ok(ForkPlan {
        header,
        root,
        seed,
        reconfigurations,
        config,
        changed,
        height,
        sealed_at,
        at,
    })
}

/// The record index of the sealing checkpoint of block `height` of the parent's final
/// canonical chain: from its sidecar index when it fits, otherwise from one fold of the log.
fn sealing_record(parent: &Path, name: &str, height: u64) -> Result<u64, ForkError> {
    let blocks = match inspect::read_sidecar(parent) {
        Some(sidecar) => sidecar.blocks,
        None => inspect::index_run(parent, None)?
            .chain
            .iter()
            .map(|r| (r.height, r.hash, r.record))
            .collect(),
    };
    let last = blocks.len() as u64 - 1;
    if height > last {
        return Err(InspectError::BlockPastEnd {
            path: name.to_string(),
            block: height,
            last,
        }
        .into());
    }
    Ok(blocks[height as usize]
        .2
        .expect("blocks after genesis have a sealing record"))
}

/// Reads `reader` up to and including record `record` and returns its time.
fn record_time(
    reader: &mut LogReader<BufReader<File>>,
    name: &str,
    record: u64,
) -> Result<SimTime, ForkError> {
    loop {
        let Some(r) = reader.next_record().map_err(ReplayError::from)? else {
            return Err(InspectError::Inconsistent {
                path: name.to_string(),
                message: format!("the log ends before record {record} named by its index"),
            }
            .into());
        };
        if reader.index() - 1 == record {
            return Ok(r.time());
        }
    }
}

/// The parent's reconfigurations up to the fork point `at` (later ones are not in the fork's
/// history) and the configuration in force there.
fn config_at(
    root: &Config,
    parent_header: &Header,
    at: SimTime,
    name: &str,
    height: u64,
) -> Result<(Vec<Reconfiguration>, Config), ForkError> {
    let mut reconfigurations: Vec<Reconfiguration> = parent_header
        .parent
        .as_ref()
        .map(|p| p.reconfigurations.clone())
        .unwrap_or_default();
    reconfigurations.retain(|r| r.at_ms <= at.0);
    let mut current = root.clone();
    for r in &reconfigurations {
        current = crate::config::parse_config(&r.config_toml, "a reconfiguration of the parent")
            .map_err(|reason| ForkError::Override {
                path: name.to_string(),
                height,
                reason,
            })?;
    }
    Ok((reconfigurations, current))
}

/// The configuration from the fork point on: `current` with the `overrides`, validated, and the
/// keys they change (at least one, each allowed to change mid-run).
fn overridden(
    current: &Config,
    overrides: &[String],
    name: &str,
    height: u64,
) -> Result<(Config, Vec<String>), ForkError> {
    let override_error = |reason| ForkError::Override {
        path: name.to_string(),
        height,
        reason,
    };
    let mut config = current.clone();
    for o in overrides {
        config.set(o).map_err(override_error)?;
    }
    config.validate().map_err(override_error)?;
    let changed = current
        .check_reconfiguration(&config)
        .map_err(override_error)?;
    if changed.is_empty() {
        return Err(ForkError::NoChange {
            path: name.to_string(),
            height,
        });
    }
    Ok((config, changed))
}

/// Checks a fork's records against its parent's, byte for byte, up to the new
/// reconfiguration: the fork's history is the parent's.
pub struct PrefixCheck {
    reader: LogReader<BufReader<File>>,
    name: String,
    crate_version: String,
    git_commit: Option<String>,
    /// Reconfigurations the parent's history also has before the new one.
    inherited: usize,
    seen: usize,
    done: bool,
    checked: u64,
    buf: Vec<u8>,
}

impl PrefixCheck {
    /// Opens the parent log of `plan`.
    pub fn open(parent: &Path, plan: &ForkPlan) -> Result<PrefixCheck, ForkError> {
        let reader = LogReader::open(parent).map_err(ReplayError::from)?;
        Ok(PrefixCheck {
            name: parent.display().to_string(),
            crate_version: reader.header().crate_version.clone(),
            git_commit: reader.header().git_commit.clone(),
            reader,
            inherited: plan.reconfigurations.len() - 1,
            seen: 0,
            done: false,
            checked: 0,
            buf: Vec::new(),
        })
    }

    /// Records found identical to the parent's so far.
    pub fn checked(&self) -> u64 {
        self.checked
    }

    /// True once the fork's own reconfiguration has been reached.
    pub fn done(&self) -> bool {
        self.done
    }

    /// Checks the fork's next record against the parent's record at the same index.
    pub fn check(&mut self, record: &Record) -> Result<(), ForkError> {
        if self.done {
            return Ok(());
        }
        if let Record::Event {
            event: Event::Reconfigure(_),
            ..
        } = record
        {
            if self.seen == self.inherited {
                self.done = true;
                return Ok(());
            }
            self.seen += 1;
        }
        let index = self.reader.index();
        let diverged = |divergence: ReplayError| ForkError::ParentDiverged {
            divergence: Box::new(divergence),
            crate_version: self.crate_version.clone(),
            commit: self
                .git_commit
                .as_ref()
                .map(|c| format!(" commit {c}"))
                .unwrap_or_default(),
        };
        let Some(logged) = self.reader.next_record().map_err(ReplayError::from)? else {
            return Err(diverged(ReplayError::Diverged {
                path: self.name.clone(),
                index,
                kind: record.kind(),
                time: record.time(),
                component: "record count".to_string(),
                detail: ": the parent log ends before the fork point".to_string(),
            }));
        };
        encode_record(record, &mut self.buf);
        if self.buf != self.reader.last_payload() {
            return Err(diverged(describe_divergence(
                &self.name, index, &logged, record,
            )));
        }
        self.checked += 1;
        Ok(())
    }
}

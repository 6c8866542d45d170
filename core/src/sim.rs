//! The driver: turns a seed and a configuration into the run's records, folding each event into
//! the reduced [`State`] as it goes.
//!
//! Two halves, kept apart on purpose:
//! - [`State`] is everything the reducers rebuild from events: replaying a log re-creates it
//!   bit-exactly without any of the driver's agents.
//! - [`Sim`] owns the agents that *decide* events (the robots' controllers, and later the
//!   sealing and gossip scheduler and the learning loop) from the current state and their own
//!   random streams. A decision becomes an [`Event`], the event is folded, then recorded.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::config::Config;
use crate::event::{Checkpoint, CheckpointCause, Event, Record};
use crate::types::{Digest, SimTime};
use crate::world::{Controllers, World, WorldError, WorldStats};

/// Why a run could not start.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The world could not be built from the configuration.
    #[error(transparent)]
    World(#[from] WorldError),
}

/// An event that the state cannot fold (only possible with a damaged or foreign log).
#[derive(Debug, thiserror::Error)]
pub enum ApplyError {
    /// The event does not fit the state (wrong robot count, unknown node, ...).
    #[error("event does not fit the state: {0}")]
    Invalid(String),
}

/// The reduced state of a run: everything rebuilt from events by pure reducers.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct State {
    /// The world: poses, sensors, data sets.
    pub world: World,
}

impl State {
    /// The state at time 0 of the run `(config, seed)`.
    pub fn genesis(config: &Config, seed: u64) -> Result<State, SimError> {
        Ok(State {
            world: World::new(config, seed)?,
        })
    }

    /// Folds one event (the reducer dispatch). Pure: no I/O, no clock, no globals.
    pub fn apply(&mut self, time: SimTime, event: &Event) -> Result<(), ApplyError> {
        match event {
            Event::Tick(tick) => {
                if time != self.world.time() {
                    return Err(ApplyError::Invalid(format!(
                        "tick at {time} but the world is at {}",
                        self.world.time()
                    )));
                }
                self.world
                    .try_apply(tick)
                    .map_err(|e| ApplyError::Invalid(e.to_string()))?;
            }
        }
        Ok(())
    }

    /// The per-component digests of the current state.
    pub fn checkpoint(&self, cause: CheckpointCause) -> Checkpoint {
        Checkpoint {
            time: self.world.time(),
            cause,
            world: self.world.digest(),
            nodes: Vec::new(),
            contract: Digest::of(b"no contract yet"),
            metrics: Digest::of(b"no metrics yet"),
        }
    }
}

/// Figures of a run for `summary.json` (the CLI adds wall-clock figures).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunSummary {
    /// Log format version.
    pub format: u32,
    /// The seed.
    pub seed: u64,
    /// The preset the configuration started from.
    pub preset: String,
    /// blake3 of the resolved configuration's TOML.
    pub config_hash: String,
    /// Simulated seconds.
    pub sim_time_s: f64,
    /// Number of robots.
    pub robots: u32,
    /// Records in the log.
    pub records: u64,
    /// Final hash of the log's chain.
    pub final_hash: String,
    /// The world's figures.
    pub world: WorldStats,
}

impl RunSummary {
    /// The summary of a finished run.
    pub fn new(
        config: &Config,
        seed: u64,
        state: &State,
        records: u64,
        final_hash: Digest,
    ) -> RunSummary {
        RunSummary {
            format: crate::log::FORMAT_VERSION,
            seed,
            preset: config.preset.clone(),
            config_hash: config.hash().to_hex().to_string(),
            sim_time_s: state.world.time().secs(),
            robots: config.world.robots,
            records,
            final_hash: final_hash.to_hex(),
            world: state.world.stats(),
        }
    }
}

/// The driver of one run: an iterator over its records.
pub struct Sim {
    config: Config,
    seed: u64,
    state: State,
    controllers: Controllers,
    tick_ms: u64,
    total_ticks: u64,
    next_tick: u64,
    checkpoint_every_ms: u64,
    queue: VecDeque<Record>,
    finished: bool,
}

impl Sim {
    /// A run of `config` seeded with `seed`, at time 0.
    pub fn new(config: Config, seed: u64) -> Result<Sim, SimError> {
        let state = State::genesis(&config, seed)?;
        let controllers = Controllers::new(&config, seed);
        let tick_ms = (config.run.tick_s * 1000.0).round() as u64;
        assert!(tick_ms > 0, "validated config has tick_s >= 1 ms");
        Ok(Sim {
            total_ticks: config.ticks(),
            checkpoint_every_ms: (config.ledger.block_period_s * 1000.0).round().max(1.0) as u64,
            config,
            seed,
            state,
            controllers,
            tick_ms,
            next_tick: 0,
            queue: VecDeque::new(),
            finished: false,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The current reduced state.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// Simulated time reached and total, in milliseconds.
    pub fn progress(&self) -> (u64, u64) {
        (
            self.next_tick * self.tick_ms,
            self.total_ticks * self.tick_ms,
        )
    }

    fn emit(&mut self, time: SimTime, event: Event) {
        self.state
            .apply(time, &event)
            .unwrap_or_else(|e| panic!("the driver produced an event its own state rejects: {e}"));
        self.queue.push_back(Record::Event { time, event });
    }

    /// Decides, folds and queues the records of the next tick.
    fn advance(&mut self) {
        if self.next_tick == self.total_ticks {
            self.queue.push_back(Record::Checkpoint(
                self.state.checkpoint(CheckpointCause::End),
            ));
            self.finished = true;
            return;
        }
        let time = SimTime(self.next_tick * self.tick_ms);
        let tick = self.controllers.decide(&self.state.world);
        self.emit(time, Event::Tick(tick));
        self.next_tick += 1;
        let now_ms = self.next_tick * self.tick_ms;
        if now_ms % self.checkpoint_every_ms == 0 && self.next_tick < self.total_ticks {
            self.queue.push_back(Record::Checkpoint(
                self.state.checkpoint(CheckpointCause::Periodic),
            ));
        }
    }
}

impl Iterator for Sim {
    type Item = Record;

    fn next(&mut self) -> Option<Record> {
        while self.queue.is_empty() && !self.finished {
            self.advance();
        }
        self.queue.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Preset;

    fn short_config() -> Config {
        let mut c = Preset::Smoke.config();
        c.run.duration_s = 30.0;
        c
    }

    #[test]
    fn a_run_is_a_pure_function_of_seed_and_config() {
        let a: Vec<Record> = Sim::new(short_config(), 3).unwrap().collect();
        let b: Vec<Record> = Sim::new(short_config(), 3).unwrap().collect();
        let c: Vec<Record> = Sim::new(short_config(), 4).unwrap().collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_eq!(a.iter().filter(|r| r.kind() == "tick").count(), 300);
        assert!(matches!(
            a.last(),
            Some(Record::Checkpoint(Checkpoint {
                cause: CheckpointCause::End,
                ..
            }))
        ));
    }

    #[test]
    fn folding_the_events_rebuilds_every_checkpoint() {
        let config = short_config();
        let mut state = State::genesis(&config, 9).unwrap();
        let mut checked = 0;
        for record in Sim::new(config, 9).unwrap() {
            match record {
                Record::Event { time, event } => state.apply(time, &event).unwrap(),
                Record::Checkpoint(c) => {
                    assert_eq!(state.checkpoint(c.cause), c);
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 3, "two periodic checkpoints and the end");
    }
}

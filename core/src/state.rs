//! The reduced state of a run and its reducers: everything rebuilt from events alone.
//!
//! [`State`] holds the world, every node's ledger with its contract states, the robots'
//! measurements and a baseline aggregation's state. Each event is folded by a pure reducer
//! ([`State::apply`]: no I/O, no clock, no globals), so replaying a log re-creates the state
//! bit-exactly without any of the driver's agents. [`apply_tick`] and [`apply_ledger_side`]
//! fold the world's and the ledger's halves on their own, so that a fold may run them on two
//! threads.

use std::sync::Arc;

use crate::aggregation::AggregationState;
use crate::config::{parse_config, Aggregation, Config};
use crate::contract::ContractParams;
use crate::event::{Checkpoint, CheckpointCause, Event, Reconfiguration};
use crate::learn::{self, ModelShape};
use crate::ledger::Ledger;
use crate::metrics::Metrics;
use crate::rng::{self, Purpose};
use crate::types::{Digest, SimTime};
use crate::world::{TickEvent, World, WorldError};

/// Why a run could not start.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The world could not be built from the configuration.
    #[error(transparent)]
    World(#[from] WorldError),
    /// The genesis model does not fit the on-chain fixed point.
    #[error("the initial model does not fit the fixed point: {0}")]
    Genesis(String),
    /// A reconfiguration (fork) cannot be applied to this run.
    #[error("reconfiguration {index} (at {at_ms} ms): {message}")]
    Reconfiguration {
        /// Its position in the list, from 0.
        index: usize,
        /// Its time.
        at_ms: u64,
        /// What is wrong.
        message: String,
    },
    /// The configuration names a plug-in the run is not given (`byzantine::plugin`).
    #[error("{0}")]
    Plugin(String),
}

/// An event that the state cannot fold (only possible with a damaged or foreign log).
#[derive(Debug, thiserror::Error)]
pub enum ApplyError {
    /// The event does not fit the state (wrong robot count, unknown node, ...).
    #[error("event does not fit the state: {0}")]
    Invalid(String),
}

/// The reduced state of a run: everything rebuilt from events by pure reducers.
#[derive(Clone, Debug)]
pub struct State {
    /// The world: poses, sensors, data sets.
    pub world: World,
    /// Every node's block tree, head, mempool and contract states.
    pub ledger: Ledger,
    /// What the robots measured.
    pub metrics: Metrics,
    /// A baseline aggregation's state (`learn.aggregation` other than `chain`; idle otherwise).
    pub aggregation: AggregationState,
    /// Digest of the fixed parameters (contract parameters and genesis block).
    pub params: Digest,
}

/// The world's reducer: folds one tick (the world must be at `time`). Independent of the ledger
/// and metrics, so a fold may run it on its own thread.
pub fn apply_tick(world: &mut World, time: SimTime, tick: &TickEvent) -> Result<(), ApplyError> {
    if time != world.time() {
        return Err(ApplyError::Invalid(format!(
            "tick at {time} but the world is at {}",
            world.time()
        )));
    }
    world
        .try_apply(tick)
        .map_err(|e| ApplyError::Invalid(e.to_string()))
}

/// The ledger's and the metrics' reducers: folds a ledger event or a learning report (any other
/// event needs the whole [`State`]). Independent of the world.
pub fn apply_ledger_side(
    ledger: &mut Ledger,
    metrics: &mut Metrics,
    time: SimTime,
    event: &Event,
) -> Result<(), ApplyError> {
    match event {
        Event::Ledger(e) => ledger
            .apply(time, e)
            .map(|_| ())
            .map_err(|e| ApplyError::Invalid(e.to_string())),
        Event::Learn(report) => {
            if report.robot >= ledger.robots() {
                return Err(ApplyError::Invalid(format!(
                    "learning report of robot {} in a swarm of {}",
                    report.robot,
                    ledger.robots()
                )));
            }
            metrics.apply(time, report);
            Ok(())
        }
        Event::Tick(_) | Event::Reconfigure(_) | Event::Aggregation(_) => Err(ApplyError::Invalid(
            format!("a {} event needs the whole state", event.kind()),
        )),
    }
}

/// The fixed-point genesis model of the run `(config, seed)` (Keras initialisation).
pub fn genesis_weights(config: &Config, seed: u64) -> Result<Arc<[i64]>, SimError> {
    let shape = ModelShape::from_config(config);
    let weights = learn::init_weights(&shape, &mut rng::stream(seed, Purpose::ModelInit, 0));
    let fixed = learn::to_fixed(&weights, config.contract.weight_scale)
        .map_err(|e| SimError::Genesis(e.to_string()))?;
    Ok(Arc::from(fixed))
}

impl State {
    /// The state at time 0 of the run `(config, seed)`.
    pub fn genesis(config: &Config, seed: u64) -> Result<State, SimError> {
        let world = World::new(config, seed)?;
        let genesis = genesis_weights(config, seed)?;
        let aggregation = AggregationState::new(config, genesis.clone());
        let params = ContractParams::from_config(config, genesis);
        // A plug-in rule that is not given is a refusal naming it, not a panic in the ledger
        // (the other checks hold for every validated configuration).
        params.check().map_err(SimError::Plugin)?;
        let mut digest = blake3::Hasher::new();
        digest.update(&rmp_serde::to_vec(&params).expect("contract parameters encode"));
        let ledger = Ledger::new(config, seed, params);
        digest.update(&ledger.genesis().0);
        Ok(State {
            world,
            ledger,
            metrics: Metrics::default(),
            aggregation,
            params: digest.finalize().into(),
        })
    }

    /// Folds one event (the reducer dispatch). Pure: no I/O, no clock, no globals.
    pub fn apply(&mut self, time: SimTime, event: &Event) -> Result<(), ApplyError> {
        match event {
            Event::Tick(tick) => apply_tick(&mut self.world, time, tick),
            Event::Reconfigure(change) => self.reconfigure(time, change),
            Event::Aggregation(e) => self.aggregation.apply(time, e).map_err(ApplyError::Invalid),
            Event::Ledger(_) | Event::Learn(_) => {
                apply_ledger_side(&mut self.ledger, &mut self.metrics, time, event)
            }
        }
    }

    /// Folds a reconfiguration: the contract's rules for the blocks sealed after `time`, and
    /// the fixed-parameter digest that checkpoints pin.
    fn reconfigure(&mut self, time: SimTime, change: &Reconfiguration) -> Result<(), ApplyError> {
        if change.at_ms != time.0 || time != self.world.time() {
            return Err(ApplyError::Invalid(format!(
                "a reconfiguration for {} ms recorded at {time} when the world is at {}",
                change.at_ms,
                self.world.time()
            )));
        }
        let config = parse_config(&change.config_toml, "the reconfiguration")
            .map_err(|e| ApplyError::Invalid(format!("reconfiguration: {e}")))?;
        if config.world.robots != self.ledger.robots() {
            return Err(ApplyError::Invalid(format!(
                "a reconfiguration to {} robots in a swarm of {}",
                config.world.robots,
                self.ledger.robots()
            )));
        }
        let params =
            ContractParams::from_config(&config, self.ledger.params().genesis_weights.clone());
        let encoded = rmp_serde::to_vec(&params).expect("contract parameters encode");
        self.ledger
            .reconfigure(time.0, params)
            .map_err(ApplyError::Invalid)?;
        let mut digest = blake3::Hasher::new();
        digest.update(&self.params.0);
        digest.update(&time.0.to_le_bytes());
        digest.update(&encoded);
        self.params = digest.finalize().into();
        Ok(())
    }

    /// The per-component digests of the current state.
    pub fn checkpoint(&self, time: SimTime, cause: CheckpointCause) -> Checkpoint {
        let robots = self.ledger.robots();
        let mut contract = blake3::Hasher::new();
        for r in 0..robots {
            contract.update(&self.ledger.head_state_digest(r).0);
        }
        Checkpoint {
            time,
            cause,
            params: self.params,
            world: self.world.digest(),
            nodes: (0..robots).map(|r| self.ledger.node_digest(r)).collect(),
            contract: contract.finalize().into(),
            metrics: self.metrics.digest(),
            aggregation: (self.aggregation.kind() != Aggregation::Chain)
                .then(|| self.aggregation.digest()),
        }
    }
}

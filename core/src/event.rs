//! The records of a run's log: events that the reducers fold, and the checkpoints that pin the
//! state they must produce.
//!
//! Events are the only inputs of the reduced state ([`crate::state::State`]): everything random or
//! decided by an agent (a wheel command, a sealing, a gossip delivery, a submitted model) is an
//! event; everything else is derived by the reducers. The log is a boundary: these types are
//! versioned by [`crate::log::FORMAT_VERSION`].

use serde::{Deserialize, Serialize};

use crate::aggregation::AggregationEvent;
use crate::ledger::LedgerEvent;
use crate::metrics::LearnReport;
use crate::types::{Digest, RobotId, SimTime};
use crate::world::TickEvent;

/// One record of the log.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Record {
    /// An event at simulated time `time`, folded by the reducers.
    Event {
        /// When the event happens.
        time: SimTime,
        /// What happens.
        event: Event,
    },
    /// The state digests the reducers must have produced after every earlier event.
    Checkpoint(Checkpoint),
}

impl Record {
    /// A short name of the record's kind, for messages ("tick", "checkpoint", ...).
    pub fn kind(&self) -> &'static str {
        match self {
            Record::Event { event, .. } => event.kind(),
            Record::Checkpoint(_) => "checkpoint",
        }
    }

    /// The record's simulated time.
    pub fn time(&self) -> SimTime {
        match self {
            Record::Event { time, .. } => *time,
            Record::Checkpoint(c) => c.time,
        }
    }
}

/// Something that happens in the simulation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Event {
    /// One world tick: every robot's wheel command (physics, sensing and data follow from it).
    Tick(TickEvent),
    /// A ledger event: a submission, a sealing, a gossip send or delivery.
    Ledger(LedgerEvent),
    /// A robot's learning phase: what it trained or forged and what it measured.
    Learn(LearnReport),
    /// The run's configuration changes here (a fork): the contract's rules for blocks sealed
    /// after this time, and everything the agents decide from now on.
    Reconfigure(Reconfiguration),
    /// A baseline aggregation's event (`learn.aggregation` = `gossip` or `central`): a
    /// stigmergy write, send or delivery, a merge, an upload.
    Aggregation(AggregationEvent),
}

/// A change of configuration in the middle of a run, at the end of a tick.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Reconfiguration {
    /// The end of the tick at which the new configuration takes over, ms (a multiple of the
    /// tick). Blocks with a later timestamp run under the new contract rules.
    pub at_ms: u64,
    /// The `key=value` overrides, as given.
    pub overrides: Vec<String>,
    /// The whole resolved configuration from then on, as TOML text.
    pub config_toml: String,
}

impl Event {
    /// A short name of the event's kind.
    pub fn kind(&self) -> &'static str {
        match self {
            Event::Tick(_) => "tick",
            Event::Ledger(e) => match e {
                LedgerEvent::Submit { .. } => "submit",
                LedgerEvent::Seal { .. } => "seal",
                LedgerEvent::Send { .. } => "send",
                LedgerEvent::Deliver { .. } => "deliver",
                LedgerEvent::Inject { .. } => "inject",
                LedgerEvent::Restart { .. } => "restart",
            },
            Event::Learn(_) => "learn",
            Event::Reconfigure(_) => "reconfigure",
            Event::Aggregation(e) => e.kind(),
        }
    }
}

/// Per-component digests of the state at a point of the run.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// Simulated time of the state.
    pub time: SimTime,
    /// Why the checkpoint was taken.
    pub cause: CheckpointCause,
    /// Digest of the run's fixed parameters: the contract's (stake, quorum, threshold, rewards,
    /// genesis model) and the genesis block they are committed to.
    pub params: Digest,
    /// Digest of the world (poses, sensors, data sets).
    pub world: Digest,
    /// Digest of each node's ledger state (head and mempool), in robot order.
    pub nodes: Vec<Digest>,
    /// Digest of the contract state at every node's head, combined in robot order.
    pub contract: Digest,
    /// Digest of the metrics accumulated so far.
    pub metrics: Digest,
    /// Digest of a baseline aggregation's state (stigmergy replicas or central server); absent
    /// in `chain` runs, so their records are unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aggregation: Option<Digest>,
}

/// Why a checkpoint was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CheckpointCause {
    /// A node sealed a block.
    Block {
        /// The sealing node.
        node: RobotId,
        /// The block's height.
        height: u64,
    },
    /// A periodic checkpoint (every block period when nothing is sealed).
    Periodic,
    /// The end of the run.
    End,
    /// The state at time 0, before any event.
    Genesis,
    /// Right after a reconfiguration (a fork point).
    Reconfigure,
}

impl Checkpoint {
    /// Names the first component whose digest differs from `other`'s, or `None` if equal.
    pub fn first_difference(&self, other: &Checkpoint) -> Option<String> {
        if self.params != other.params {
            return Some(
                "the run's fixed parameters (contract parameters or genesis model: the seeds or \
                 contract configurations differ, or the code that derives them changed)"
                    .to_string(),
            );
        }
        if self.world != other.world {
            return Some("world".to_string());
        }
        if self.nodes.len() != other.nodes.len() {
            return Some(format!(
                "ledger (node count {} vs {})",
                self.nodes.len(),
                other.nodes.len()
            ));
        }
        if let Some(i) = self
            .nodes
            .iter()
            .zip(&other.nodes)
            .position(|(a, b)| a != b)
        {
            return Some(format!("ledger node {i}"));
        }
        if self.contract != other.contract {
            return Some("contract".to_string());
        }
        if self.metrics != other.metrics {
            return Some("metrics".to_string());
        }
        if self.aggregation != other.aggregation {
            return Some("aggregation (stigmergy replicas or central server)".to_string());
        }
        if self.time != other.time || self.cause != other.cause {
            return Some("checkpoint time or cause".to_string());
        }
        None
    }
}

//! swarmfl-core: a deterministic, event-sourced simulation of a robot swarm that trains a shared
//! model by federated learning, secured by a per-robot proof-of-authority blockchain.
//!
//! A run is a seed plus a [`config::Config`]. The driver ([`sim`]) turns them into a stream of
//! [`event::Event`]s, each folded into the state by a pure reducer (physics in [`world`], the
//! nodes in [`ledger`], the smart contract in [`contract`]) and appended to a hash-chained log
//! ([`log`]). Replaying the log through the same reducers rebuilds every state bit-exactly.
//! See ARCHITECTURE.md for the map and the invariants.

pub mod aggregation;
pub mod byzantine;
pub mod chaos;
pub mod config;
pub mod contract;
pub mod data;
pub mod diff;
pub mod event;
pub mod faults;
pub mod fork;
pub mod inspect;
pub mod learn;
pub mod ledger;
pub mod log;
pub mod metrics;
pub mod radio;
pub mod replay;
pub mod rng;
pub mod sim;
pub mod state;
pub mod summary;
pub mod types;
pub mod world;

pub use config::Config;
pub use types::{Digest, RobotId, SimTime};

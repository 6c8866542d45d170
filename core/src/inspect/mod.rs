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
//! - for the one height asked for (if any), clones the full [`State`](crate::state::State) at
//!   the checkpoint of each block sealed at that height (one per competing fork, usually one),
//!   and keeps the clone of the block that turns out canonical.
//!
//! So `inspect` costs one fold of the log plus one `State` clone per block sealed at the asked
//! height. The contract state after *every* block needs no fold at all: every
//! [`crate::ledger::BlockEntry`] of the final ledger carries it, which is what `bisect` and
//! `export` read (node head heights come from the index).
//!
//! # Sidecar index instead of snapshots
//!
//! The final canonical chain (which block *is* height H) is only known at the end of the log,
//! so a first lookup needs the whole fold; `swarmfl inspect` then writes the sidecar index `LOG.idx` ([`Sidecar`]:
//! the final canonical chain with every block's sealing-checkpoint record index, tied to the log
//! by its size and footer); later lookups ([`block_report_indexed`]) fold only up to the block.
//!
//! The index exists because a lookup without it repeats the whole fold, and on a paper-sized log
//! that fold, not the report, is the cost; with the index the cost grows with the asked height.
//! The timings are in docs/PERFORMANCE.md, "Replay, inspect and bisect".
//!
//! Full-state snapshots every `output.snapshot_every_blocks` blocks are kept in memory by a
//! [`Seeker`] (`seek.rs`): the state, last learning reports, configuration and reader position
//! right after the sealing of every such block of the final canonical chain that a lookup
//! folded past, so later lookups of the same log (the Python package's `Run.at(block=...)`)
//! fold only from the nearest one. Written beside the log they would need serde for `Ledger`
//! and `World` (not derived today: the ledger shares blocks and transactions through `Arc`s,
//! the world holds its random streams); at the paper's scale one fold stays below the 1 s
//! target (docs/PERFORMANCE.md), so they are not written.

//! # Files
//!
//! By the question they answer: `index.rs` (the one fold that indexes the final canonical
//! chain, [`index_run`]), `fold.rs` (the record fold shared by the index and a block's report),
//! `sidecar.rs` (`LOG.idx`), `seek.rs` (lookups from in-memory snapshots, [`Seeker`]), `at_block.rs` (the state at a block, [`block_report`]),
//! `values.rs` (per-block values for predicates), `bisect.rs` (the first block where a
//! predicate holds), `export.rs` (the closed rounds), `tables.rs` (every table `swarmfl export`
//! writes and the Python package loads, as typed columns), `ranking.rs` (where each
//! submission sat in its round's ranking, `swarmfl ranking`), `traffic.rs` (bytes sent and
//! stored per node over time, `swarmfl traffic`) and `error.rs`.
//! A baseline run (no blocks) is looked into by time instead, in [`timeline`]. The predicate
//! language of `bisect` is in [`expr`] (grammar in its module docs).

mod at_block;
mod bisect;
mod error;
mod export;
pub mod expr;
mod fold;
mod index;
mod ranking;
mod seek;
mod sidecar;
mod tables;
pub mod timeline;
mod traffic;
mod values;

#[cfg(test)]
mod tests;

pub use at_block::{
    block_report, BalanceInfo, BlockInfo, BlockReport, ContractInfo, NodeInfo, RobotInfo,
    RobotView, RoundInfo, SubmissionInfo, TxInfo, WorldInfo,
};
pub use bisect::{bisect, profile, BisectHit, Profile};
pub use error::InspectError;
pub use export::RoundRow;
pub use expr::{EvalError, Expr, ParseError};
pub use fold::LastLearning;
pub use index::{index_run, BlockRow, ChainBytesRow, Indexer, RunIndex, StateAtBlock};
pub use ranking::{rank_round, RankedSubmission};
pub use seek::{block_report_indexed, Seeker, MAX_SNAPSHOTS};
pub use sidecar::{read_sidecar, sidecar_path, Sidecar, SIDECAR_VERSION};
pub use tables::{poses_table, Column, Table};
pub use traffic::{traffic, Spread, Traffic, TrafficRow, MAX_PERIOD_MS};
pub use values::{BlockValues, ChainValues};

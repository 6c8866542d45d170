//! The `swarmfl._swarmfl` extension module: thin PyO3 bindings over the study crate
//! (`swarmfl_study`: runs, forks, sweeps, reports, exports, pictures) and the core's tables
//! (`swarmfl_core::inspect`). Nothing is computed
//! here that the command does not compute the same way; the Python side (`swarmfl/`) only turns
//! the columns into pandas data frames.
//!
//! Built with the `python` feature (maturin sets it, see pyproject.toml). Without it the crate
//! is empty, so the workspace's `cargo test` needs no Python.

#[cfg(feature = "python")]
mod bindings;
#[cfg(feature = "python")]
mod plugins;
#[cfg(feature = "python")]
mod watch;

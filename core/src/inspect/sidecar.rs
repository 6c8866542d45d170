//! The sidecar index `LOG.idx`: a log's final canonical chain saved by a first lookup, so later
//! ones fold only up to their block.

use std::path::Path;

use serde::Serialize;

use super::error::InspectError;
use super::index::RunIndex;
use crate::replay::ReplayError;
use crate::types::Digest;

/// The sidecar index of a log (`LOG.idx`, JSON): its final canonical chain with the record
/// index of every block's sealing checkpoint, tied to the log by its size and the digest of its
/// last 64 bytes (the footer, which holds the log's final hash). With it, `inspect` folds the
/// log only up to the block instead of to the end.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct Sidecar {
    /// Sidecar format version ([`SIDECAR_VERSION`]).
    pub version: u32,
    /// Size of the log in bytes.
    pub log_bytes: u64,
    /// blake3 of the log's last 64 bytes, hex.
    pub tail: String,
    /// The final canonical chain: (height, block id, sealing checkpoint record; none for genesis).
    pub blocks: Vec<(u64, Digest, Option<u64>)>,
}

/// Version of the [`Sidecar`] format.
pub const SIDECAR_VERSION: u32 = 1;

/// `LOG.idx` next to `LOG`.
pub fn sidecar_path(log: &Path) -> std::path::PathBuf {
    let mut name = log.as_os_str().to_os_string();
    name.push(".idx");
    std::path::PathBuf::from(name)
}

/// A log's size and the blake3 of its last 64 bytes (hex): what ties a sidecar to it.
pub(super) fn log_identity(path: &Path) -> Result<(u64, String), InspectError> {
    use std::io::{Read, Seek, SeekFrom};
    let io = |e: std::io::Error| {
        InspectError::Replay(ReplayError::Log(crate::log::LogError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        }))
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    file.seek(SeekFrom::Start(len.saturating_sub(64)))
        .map_err(io)?;
    let mut tail = Vec::new();
    file.read_to_end(&mut tail).map_err(io)?;
    Ok((len, blake3::hash(&tail).to_hex().to_string()))
}

impl RunIndex {
    /// The sidecar index of this run.
    pub fn sidecar(&self, log: &Path) -> Result<Sidecar, InspectError> {
        let (log_bytes, tail) = log_identity(log)?;
        Ok(Sidecar {
            version: SIDECAR_VERSION,
            log_bytes,
            tail,
            blocks: self
                .chain
                .iter()
                .map(|r| (r.height, r.hash, r.record))
                .collect(),
        })
    }
}

/// Reads `LOG.idx` if it exists and belongs to this very log; `None` otherwise (absent, stale,
/// another version or unreadable: the caller then folds the whole log and rewrites it).
pub fn read_sidecar(log: &Path) -> Option<Sidecar> {
    let text = std::fs::read_to_string(sidecar_path(log)).ok()?;
    let sidecar: Sidecar = serde_json::from_str(&text).ok()?;
    let (log_bytes, tail) = log_identity(log).ok()?;
    let fits = sidecar.version == SIDECAR_VERSION
        && sidecar.log_bytes == log_bytes
        && sidecar.tail == tail
        && !sidecar.blocks.is_empty()
        && sidecar
            .blocks
            .iter()
            .enumerate()
            .all(|(i, b)| b.0 == i as u64 && (i == 0) == b.2.is_none());
    fits.then_some(sidecar)
}

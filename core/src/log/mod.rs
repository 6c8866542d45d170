//! The run log: a self-describing header, then length-prefixed rmp-serde records folded into a
//! blake3 hash chain, then a footer with the final hash. Written and read as a stream.
//!
//! Layout (all integers little-endian):
//!
//! ```text
//! magic    "SWARMFL\0"                      8 bytes
//! version  u32                              FORMAT_VERSION (2; version 1 is still read)
//! hlen     u32, header: rmp-serde (named)   Header
//! htag     [u8; 8]                          first 8 bytes of blake3(header bytes)
//! frames   version 2: kind u8 | len u32 | check [u8; 4] | tag [u8; 4] | payload (len bytes)
//!          version 1: kind u8 | len u32 | tag [u8; 8] | payload (len bytes)
//!          kind 1 = record (payload: rmp-serde Record), kind 2 = footer (payload: Footer)
//! ```
//!
//! The chain starts at `h0 = blake3("swarmfl-log" | 1 | run identity)`, where 1 is
//! [`RECORD_VERSION`] and the identity is the seed, the resolved configuration and the fork
//! origin (not the build provenance, so that the same run made by two builds has the same final
//! hash), and folds every frame's payload: `h(i+1) = blake3(h(i) | payload)`. The chain is the
//! same in both layouts, so a run's final hash does not depend on the layout that stored it.
//!
//! A frame's tag is the first bytes of its chain value (8 in version 1, 4 in version 2), so a
//! flipped bit is caught at the very record it hits; the footer carries the whole final hash and
//! the record count. In version 2 the frame's `check` (first 4 bytes of
//! `blake3("swarmfl-frame" | h(i) | kind | len)`) covers the kind and the length and ties them
//! to the frame's place in the chain, so a damaged length is found before the payload is read
//! and reported as corruption, never as a cut log. (In version 1 a length made larger than the
//! rest of the file reads as a truncation.) Both layouts have 13-byte frame headers, so a run's
//! log has the same size in either (`summary.json`'s `log_bytes`).
//!
//! A cut or damaged log is reported with the byte offset and record index of the first bad
//! frame and the last good checkpoint, and every record before it stays readable.
//!
//! The chain is not keyed: it shows that a log was not damaged, not who wrote it. Whoever edits
//! a log can recompute the chain; only a re-simulation (`swarmfl replay --resimulate`) shows that
//! the records are those of the header's seed and configuration.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::event::Record;
use crate::types::{Digest, SimTime};

/// The first bytes of every log.
pub const MAGIC: &[u8; 8] = b"SWARMFL\0";
/// The version of the layout this build writes; bumped on any incompatible change. Version 2
/// added the frame header check; this build reads versions 1 and 2.
pub const FORMAT_VERSION: u32 = 2;
/// The oldest layout version this build reads.
pub const OLDEST_FORMAT_VERSION: u32 = 1;
/// The version of the record types and of the hash chain's start (`h0`), which the layouts
/// 1 and 2 share: it is what a run's final hash depends on, and what `summary.json`'s `format`
/// records. Bumped only when the records' encoding changes (which moves every hash).
pub const RECORD_VERSION: u32 = 1;
/// Largest payload a frame may carry; a larger length is taken as corruption.
pub const MAX_PAYLOAD_BYTES: u32 = 1 << 28;

const KIND_RECORD: u8 = 1;
const KIND_FOOTER: u8 = 2;
const FRAME_OVERHEAD: u64 = 13;

/// The git commit this build was made from (`core/build.rs` asks `git rev-parse HEAD`), or
/// `None` when it was built outside a git checkout. Every log's header records it, and
/// `swarmfl --version` prints it.
pub const GIT_COMMIT: Option<&str> = match option_env!("SWARMFL_GIT_COMMIT") {
    Some(commit) if !commit.is_empty() => Some(commit),
    _ => None,
};

/// The self-describing header of a log: enough to re-simulate the run and to know what made it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// Layout version (equals the file's version field).
    pub format_version: u32,
    /// Version of swarmfl-core that wrote the log.
    pub crate_version: String,
    /// Git commit of the source, when known at build time.
    pub git_commit: Option<String>,
    /// `rustc --version` of the compiler, when known at build time.
    pub rustc_version: Option<String>,
    /// Target triple of the build.
    pub target: String,
    /// The run's seed.
    pub seed: u64,
    /// The fully resolved configuration, as TOML text.
    pub config_toml: String,
    /// For a forked run: the parent log and the block height it was forked at.
    pub parent: Option<ForkOrigin>,
    /// The plug-ins the run uses (name and source digest, see `byzantine::plugin`). Left out
    /// of the header and of the run identity when empty, so runs without plug-ins keep their
    /// bytes and hashes; part of the identity otherwise (another source is another run).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plugins: Vec<crate::byzantine::plugin::PluginId>,
}

/// Where a forked run came from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ForkOrigin {
    /// Final hash of the parent log.
    pub parent_final_hash: Digest,
    /// Block height of the fork point on the parent's final canonical chain.
    pub height: u64,
    /// Overrides applied at the fork.
    pub overrides: Vec<String>,
    /// Every reconfiguration of the run since the header's configuration, oldest first: the
    /// parent's own (when the parent is itself a fork) and then this fork's. Re-simulation
    /// applies them at their times.
    pub reconfigurations: Vec<crate::event::Reconfiguration>,
}

impl Header {
    /// A header for a new run of this build.
    pub fn new(seed: u64, config_toml: String) -> Header {
        Header {
            format_version: FORMAT_VERSION,
            crate_version: env!("CARGO_PKG_VERSION").to_string(),
            git_commit: GIT_COMMIT.map(str::to_string),
            rustc_version: option_env!("SWARMFL_RUSTC_VERSION")
                .filter(|s| !s.is_empty())
                .map(str::to_string),
            target: option_env!("SWARMFL_TARGET")
                .unwrap_or("unknown")
                .to_string(),
            seed,
            config_toml,
            parent: None,
            plugins: Vec::new(),
        }
    }
}

/// The last frame of a complete log.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Footer {
    /// Number of records before the footer.
    pub records: u64,
    /// The chain hash after the last record: names the whole run.
    pub final_hash: Digest,
}

/// Where the last good checkpoint of a damaged log is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GoodCheckpoint {
    /// Its record index.
    pub index: u64,
    /// Its simulated time.
    pub time: SimTime,
}

fn describe_checkpoint(c: &Option<GoodCheckpoint>) -> String {
    match c {
        Some(c) => format!(
            "the last good checkpoint is record {} at t = {}",
            c.index, c.time
        ),
        None => "no checkpoint precedes it".to_string(),
    }
}

/// What is wrong with a log file (or with writing one).
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// The file could not be opened, read or written.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The file does not start with the swarmfl magic bytes.
    #[error("{path}: not a swarmfl log (the first 8 bytes are not \"SWARMFL\\0\"); pass the run.swlog file that `swarmfl run` wrote")]
    NotALog {
        /// The file.
        path: String,
    },
    /// The log was written in another format version.
    #[error("{path}: log format version {found}, but this swarmfl (v{crate_version}) reads versions {OLDEST_FORMAT_VERSION} to {supported}; replay it with the swarmfl version that wrote it, or re-run the simulation with this one")]
    Version {
        /// The file.
        path: String,
        /// Version found in the file.
        found: u32,
        /// Newest version this build reads.
        supported: u32,
        /// This build's crate version.
        crate_version: &'static str,
    },
    /// The header cannot be decoded.
    #[error("{path}: damaged header at byte offset {offset}: {message}; the log cannot be replayed, re-run the simulation")]
    Header {
        /// The file.
        path: String,
        /// Byte offset of the header.
        offset: u64,
        /// The decoder's message.
        message: String,
    },
    /// The log ends early: a frame is cut, or the footer is missing.
    #[error("{path}: log is truncated at byte offset {offset}, record {index}: {message}; records 0..{index} are intact and {checkpoint}. Re-run the simulation to get the whole log, or inspect the intact prefix", checkpoint = describe_checkpoint(last_good_checkpoint))]
    Truncated {
        /// The file.
        path: String,
        /// Byte offset of the incomplete frame (or of the end of the file).
        offset: u64,
        /// Index of the first record that is missing.
        index: u64,
        /// What is missing.
        message: String,
        /// The last checkpoint before the damage.
        last_good_checkpoint: Option<GoodCheckpoint>,
    },
    /// A frame is damaged: bad kind, absurd length, broken hash chain or undecodable payload.
    #[error("{path}: corrupt record {index} at byte offset {offset}: {message}; records 0..{index} are intact and {checkpoint}. The file was altered after it was written: re-run the simulation with the seed and config in its header", checkpoint = describe_checkpoint(last_good_checkpoint))]
    Corrupt {
        /// The file.
        path: String,
        /// Byte offset of the damaged frame.
        offset: u64,
        /// Index of the damaged record.
        index: u64,
        /// What is wrong.
        message: String,
        /// The last checkpoint before the damage.
        last_good_checkpoint: Option<GoodCheckpoint>,
    },
    /// An intact record (its hash chain verifies) of a kind this build does not know: the log
    /// was written by another build of the same format version that has more record kinds.
    #[error("{path}: record {index} at byte offset {offset} is intact (its hash chain verifies) but this build cannot decode it ({message}); the log was written by swarmfl {crate_version}{commit}, which knows record kinds this build does not: read it with that build or a newer one", commit = commit_suffix(git_commit))]
    UnknownRecord {
        /// The file.
        path: String,
        /// Byte offset of the record's frame.
        offset: u64,
        /// Index of the record.
        index: u64,
        /// The decoder's message.
        message: String,
        /// The writer's crate version (from the header).
        crate_version: String,
        /// The writer's commit, when known.
        git_commit: Option<String>,
    },
}

/// The " commit abc" part of a build description, when the commit is known.
fn commit_suffix(commit: &Option<String>) -> String {
    commit
        .as_ref()
        .map(|c| format!(" (commit {c})"))
        .unwrap_or_default()
}

impl LogError {
    /// The record index of the damage, for errors that have one.
    pub fn record_index(&self) -> Option<u64> {
        match self {
            LogError::Truncated { index, .. }
            | LogError::Corrupt { index, .. }
            | LogError::UnknownRecord { index, .. } => Some(*index),
            _ => None,
        }
    }

    /// The byte offset of the damage, for errors that have one.
    pub fn offset(&self) -> Option<u64> {
        match self {
            LogError::Truncated { offset, .. }
            | LogError::Corrupt { offset, .. }
            | LogError::UnknownRecord { offset, .. }
            | LogError::Header { offset, .. } => Some(*offset),
            _ => None,
        }
    }
}

/// The running blake3 hash chain over a log's frames.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HashChain {
    value: [u8; 32],
}

impl HashChain {
    /// The chain's start for a run: its identity (seed, configuration, fork origin, and the
    /// plug-ins' ids when there are any).
    pub fn start(header: &Header) -> HashChain {
        let identity = (header.seed, &header.config_toml, &header.parent);
        let mut h = blake3::Hasher::new();
        h.update(b"swarmfl-log");
        h.update(&RECORD_VERSION.to_le_bytes());
        h.update(&rmp_serde::to_vec(&identity).expect("identity encodes"));
        if !header.plugins.is_empty() {
            h.update(&rmp_serde::to_vec(&header.plugins).expect("plug-in ids encode"));
        }
        HashChain {
            value: *h.finalize().as_bytes(),
        }
    }

    /// Folds one payload; returns the frame tag (first 8 bytes of the new value).
    pub fn fold(&mut self, payload: &[u8]) -> [u8; 8] {
        let mut h = blake3::Hasher::new();
        h.update(&self.value);
        h.update(payload);
        self.value = *h.finalize().as_bytes();
        self.tag()
    }

    /// The version-2 frame check of the next frame, of `kind` and payload length `len`: the
    /// first 4 bytes of `blake3("swarmfl-frame" | current value | kind | len)`. It covers the
    /// frame header's fields and ties them to the frame's place in the chain.
    pub fn frame_check(&self, kind: u8, len: u32) -> [u8; 4] {
        let mut h = blake3::Hasher::new();
        h.update(b"swarmfl-frame");
        h.update(&self.value);
        h.update(&[kind]);
        h.update(&len.to_le_bytes());
        let mut check = [0u8; 4];
        check.copy_from_slice(&h.finalize().as_bytes()[..4]);
        check
    }

    /// The tag of the current value.
    pub fn tag(&self) -> [u8; 8] {
        let mut tag = [0u8; 8];
        tag.copy_from_slice(&self.value[..8]);
        tag
    }

    /// The current chain value.
    pub fn digest(&self) -> Digest {
        Digest(self.value)
    }
}

/// Encodes a record the way the log stores it (compact rmp-serde).
pub fn encode_record(record: &Record, buf: &mut Vec<u8>) {
    buf.clear();
    rmp_serde::encode::write(buf, record).expect("records always encode");
}

/// Writes a log as a stream.
pub struct LogWriter<W: Write> {
    out: W,
    path: String,
    chain: HashChain,
    records: u64,
    bytes: u64,
    buf: Vec<u8>,
}

impl LogWriter<BufWriter<File>> {
    /// Creates (or replaces) the log file at `path` and writes its header.
    pub fn create(path: &Path, header: &Header) -> Result<Self, LogError> {
        let io = |e: std::io::Error| LogError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        let file = File::create(path).map_err(io)?;
        LogWriter::new(
            BufWriter::with_capacity(1 << 20, file),
            &path.display().to_string(),
            header,
        )
    }
}

impl<W: Write> LogWriter<W> {
    /// Writes the header of a log into `out`; `name` names it in errors.
    pub fn new(mut out: W, name: &str, header: &Header) -> Result<Self, LogError> {
        assert_eq!(header.format_version, FORMAT_VERSION);
        let header_bytes = rmp_serde::to_vec_named(header).expect("headers always encode");
        let io = |e: std::io::Error| LogError::Io {
            path: name.to_string(),
            message: e.to_string(),
        };
        out.write_all(MAGIC).map_err(io)?;
        out.write_all(&FORMAT_VERSION.to_le_bytes()).map_err(io)?;
        out.write_all(&(header_bytes.len() as u32).to_le_bytes())
            .map_err(io)?;
        out.write_all(&header_bytes).map_err(io)?;
        out.write_all(&blake3::hash(&header_bytes).as_bytes()[..8])
            .map_err(io)?;
        Ok(LogWriter {
            out,
            path: name.to_string(),
            chain: HashChain::start(header),
            records: 0,
            bytes: 24 + header_bytes.len() as u64,
            buf: Vec::with_capacity(1 << 16),
        })
    }

    /// Appends one record.
    pub fn append(&mut self, record: &Record) -> Result<(), LogError> {
        let mut buf = std::mem::take(&mut self.buf);
        encode_record(record, &mut buf);
        let result = self.write_frame(KIND_RECORD, &buf);
        self.buf = buf;
        self.records += 1;
        result
    }

    fn write_frame(&mut self, kind: u8, payload: &[u8]) -> Result<(), LogError> {
        assert!(
            payload.len() <= MAX_PAYLOAD_BYTES as usize,
            "record of {} bytes",
            payload.len()
        );
        let len = payload.len() as u32;
        let check = self.chain.frame_check(kind, len);
        let tag = self.chain.fold(payload);
        let io = |e: std::io::Error| LogError::Io {
            path: self.path.clone(),
            message: e.to_string(),
        };
        let mut head = [0u8; FRAME_OVERHEAD as usize];
        head[0] = kind;
        head[1..5].copy_from_slice(&len.to_le_bytes());
        head[5..9].copy_from_slice(&check);
        head[9..13].copy_from_slice(&tag[..4]);
        self.out.write_all(&head).map_err(io)?;
        self.out.write_all(payload).map_err(io)?;
        self.bytes += FRAME_OVERHEAD + payload.len() as u64;
        Ok(())
    }

    /// Records written so far.
    pub fn records(&self) -> u64 {
        self.records
    }

    /// Bytes written so far.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// The chain hash after the last record.
    pub fn chain_hash(&self) -> Digest {
        self.chain.digest()
    }

    /// Writes the footer and flushes; returns the footer and the underlying writer.
    pub fn finish(mut self) -> Result<(Footer, W), LogError> {
        let footer = Footer {
            records: self.records,
            final_hash: self.chain.digest(),
        };
        let payload = rmp_serde::to_vec(&footer).expect("footers always encode");
        self.write_frame(KIND_FOOTER, &payload)?;
        self.out.flush().map_err(|e| LogError::Io {
            path: self.path.clone(),
            message: e.to_string(),
        })?;
        Ok((footer, self.out))
    }
}

mod reader;

pub use reader::{directory_hint, LogReader, Next, Position};

#[cfg(test)]
mod tests;

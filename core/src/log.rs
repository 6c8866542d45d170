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
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
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

/// Reads a log as a stream, verifying the hash chain at every frame.
pub struct LogReader<R: Read> {
    input: R,
    path: String,
    /// The file's layout version ([`OLDEST_FORMAT_VERSION`] to [`FORMAT_VERSION`]).
    version: u32,
    header: Header,
    header_bytes: Vec<u8>,
    chain: HashChain,
    offset: u64,
    index: u64,
    last_checkpoint: Option<GoodCheckpoint>,
    footer: Option<Footer>,
    payload: Vec<u8>,
}

impl LogReader<BufReader<File>> {
    /// Opens the log at `path` and reads its header.
    pub fn open(path: &Path) -> Result<Self, LogError> {
        if path.is_dir() {
            return Err(LogError::Io {
                path: path.display().to_string(),
                message: directory_hint(path),
            });
        }
        let file = File::open(path).map_err(|e| LogError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        LogReader::new(
            BufReader::with_capacity(1 << 20, file),
            &path.display().to_string(),
        )
    }
}

/// What to give instead of the directory `dir` where a log is expected (the message follows
/// `dir: `): its `run.swlog` when it holds one, else what a run's directory holds.
pub fn directory_hint(dir: &Path) -> String {
    let log = dir.join("run.swlog");
    if log.is_file() {
        format!(
            "is a directory: give {} (the log the run wrote there)",
            log.display()
        )
    } else {
        "is a directory and holds no run.swlog: give a log file (`swarmfl run --out DIR` writes \
         DIR/run.swlog)"
            .to_string()
    }
}

/// Replaces `buf` with the next `len` bytes of `input`, or with fewer if the input ends first.
/// The buffer grows with the bytes actually read, so a damaged length field on a short file
/// fails fast instead of allocating the whole claimed length up front.
fn read_exact_or_less<R: Read>(input: &mut R, len: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
    buf.clear();
    input.take(len).read_to_end(buf)?;
    Ok(())
}

/// Reads until `buf` is full or the input ends; returns the bytes read.
fn read_full<R: Read>(input: &mut R, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match input.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

impl<R: Read> LogReader<R> {
    /// Reads the header from `input`; `name` names the log in errors.
    pub fn new(mut input: R, name: &str) -> Result<Self, LogError> {
        let io = |e: std::io::Error| LogError::Io {
            path: name.to_string(),
            message: e.to_string(),
        };
        let mut fixed = [0u8; 16];
        let n = read_full(&mut input, &mut fixed).map_err(io)?;
        if n < 8 || &fixed[..8] != MAGIC {
            return Err(LogError::NotALog {
                path: name.to_string(),
            });
        }
        if n < 16 {
            return Err(LogError::Header {
                path: name.to_string(),
                offset: 8,
                message: format!("the file ends after {n} bytes, inside the fixed header"),
            });
        }
        let version = u32::from_le_bytes(fixed[8..12].try_into().expect("4 bytes"));
        if !(OLDEST_FORMAT_VERSION..=FORMAT_VERSION).contains(&version) {
            return Err(LogError::Version {
                path: name.to_string(),
                found: version,
                supported: FORMAT_VERSION,
                crate_version: env!("CARGO_PKG_VERSION"),
            });
        }
        let header_len = u32::from_le_bytes(fixed[12..16].try_into().expect("4 bytes"));
        if header_len > MAX_PAYLOAD_BYTES {
            return Err(LogError::Header {
                path: name.to_string(),
                offset: 16,
                message: format!("header length {header_len} is absurd"),
            });
        }
        let mut header_bytes = Vec::new();
        read_exact_or_less(&mut input, u64::from(header_len) + 8, &mut header_bytes).map_err(io)?;
        let got = header_bytes.len();
        if got < header_len as usize + 8 {
            return Err(LogError::Header {
                path: name.to_string(),
                offset: 16,
                message: format!(
                    "the file ends inside the header ({got} of {} bytes)",
                    header_len + 8
                ),
            });
        }
        let header_tag = header_bytes.split_off(header_len as usize);
        if header_tag[..] != blake3::hash(&header_bytes).as_bytes()[..8] {
            return Err(LogError::Header {
                path: name.to_string(),
                offset: 16,
                message: "header checksum mismatch: the header bytes were altered".to_string(),
            });
        }
        let header: Header =
            rmp_serde::from_slice(&header_bytes).map_err(|e| LogError::Header {
                path: name.to_string(),
                offset: 16,
                message: e.to_string(),
            })?;
        if header.format_version != version {
            return Err(LogError::Header {
                path: name.to_string(),
                offset: 16,
                message: format!(
                    "header says format version {} but the file says {version}",
                    header.format_version
                ),
            });
        }
        Ok(LogReader {
            input,
            path: name.to_string(),
            version,
            chain: HashChain::start(&header),
            header,
            header_bytes,
            offset: 24 + u64::from(header_len),
            index: 0,
            last_checkpoint: None,
            footer: None,
            payload: Vec::new(),
        })
    }

    /// The file's layout version (1 or 2; see the module documentation).
    pub fn format_version(&self) -> u32 {
        self.version
    }

    /// The log's header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The header's encoded bytes (what the chain starts from).
    pub fn header_bytes(&self) -> &[u8] {
        &self.header_bytes
    }

    /// The footer, once [`LogReader::next_record`] has returned `Ok(None)`.
    pub fn footer(&self) -> Option<Footer> {
        self.footer
    }

    /// Index of the next record.
    pub fn index(&self) -> u64 {
        self.index
    }

    /// Byte offset of the next frame.
    pub fn offset(&self) -> u64 {
        self.offset
    }

    /// The chain hash after the records read so far.
    pub fn chain_hash(&self) -> Digest {
        self.chain.digest()
    }

    /// The last checkpoint read so far.
    pub fn last_checkpoint(&self) -> Option<GoodCheckpoint> {
        self.last_checkpoint
    }

    fn truncated(&self, offset: u64, message: String) -> LogError {
        LogError::Truncated {
            path: self.path.clone(),
            offset,
            index: self.index,
            message,
            last_good_checkpoint: self.last_checkpoint,
        }
    }

    fn corrupt(&self, offset: u64, message: String) -> LogError {
        LogError::Corrupt {
            path: self.path.clone(),
            offset,
            index: self.index,
            message,
            last_good_checkpoint: self.last_checkpoint,
        }
    }

    /// Reads the next record; `Ok(None)` after a verified footer. After an error the reader
    /// must not be used further; every record returned before it was verified.
    pub fn next_record(&mut self) -> Result<Option<Record>, LogError> {
        if self.footer.is_some() {
            return Ok(None);
        }
        let frame_offset = self.offset;
        let mut head = [0u8; FRAME_OVERHEAD as usize];
        let n = read_full(&mut self.input, &mut head).map_err(|e| LogError::Io {
            path: self.path.clone(),
            message: e.to_string(),
        })?;
        if n == 0 {
            return Err(self.truncated(frame_offset, "the file ends without a footer".to_string()));
        }
        if n < head.len() {
            return Err(self.truncated(
                frame_offset,
                format!("the file ends inside a frame header ({n} of 13 bytes)"),
            ));
        }
        let kind = head[0];
        let len = u32::from_le_bytes(head[1..5].try_into().expect("4 bytes"));
        if kind != KIND_RECORD && kind != KIND_FOOTER {
            return Err(self.corrupt(frame_offset, format!("unknown frame kind {kind}")));
        }
        // Version 2: the kind and the length are checked before the payload is read, so a
        // damaged length is corruption at this frame, never a cut log.
        if self.version >= 2 && head[5..9] != self.chain.frame_check(kind, len) {
            return Err(self.corrupt(
                frame_offset,
                format!(
                    "frame header check failed: the frame's kind ({kind}) or length ({len}) \
                     bytes were altered, or the frame is not the one that belongs here"
                ),
            ));
        }
        if len > MAX_PAYLOAD_BYTES {
            return Err(self.corrupt(
                frame_offset,
                format!("frame length {len} exceeds the maximum {MAX_PAYLOAD_BYTES}"),
            ));
        }
        read_exact_or_less(&mut self.input, u64::from(len), &mut self.payload).map_err(|e| {
            LogError::Io {
                path: self.path.clone(),
                message: e.to_string(),
            }
        })?;
        let got = self.payload.len();
        if got < len as usize {
            return Err(self.truncated(
                frame_offset,
                format!("the file ends inside a frame ({got} of {len} payload bytes)"),
            ));
        }
        let mut chain = self.chain.clone();
        let tag = chain.fold(&self.payload);
        let tag_ok = match self.version {
            1 => tag[..] == head[5..13],
            _ => tag[..4] == head[9..13],
        };
        if !tag_ok {
            return Err(self.corrupt(
                frame_offset,
                "hash chain broken: the frame's bytes (or its length or tag) were altered"
                    .to_string(),
            ));
        }
        if kind == KIND_FOOTER {
            let footer: Footer = rmp_serde::from_slice(&self.payload)
                .map_err(|e| self.corrupt(frame_offset, format!("undecodable footer: {e}")))?;
            if footer.records != self.index || footer.final_hash != self.chain.digest() {
                return Err(self.corrupt(
                    frame_offset,
                    format!(
                        "footer says {} records and final hash {}, but the log has {} records with hash {}",
                        footer.records,
                        footer.final_hash.short(),
                        self.index,
                        self.chain.digest().short()
                    ),
                ));
            }
            let mut extra = [0u8; 1];
            let trailing = read_full(&mut self.input, &mut extra).map_err(|e| LogError::Io {
                path: self.path.clone(),
                message: e.to_string(),
            })?;
            if trailing != 0 {
                return Err(self.corrupt(
                    frame_offset + FRAME_OVERHEAD + u64::from(len),
                    "bytes follow the footer".to_string(),
                ));
            }
            // The chain stays at the final hash (the footer's tag folds the footer itself).
            self.offset += FRAME_OVERHEAD + u64::from(len);
            self.footer = Some(footer);
            return Ok(None);
        }
        // The chain verified, so the bytes are the writer's: a record that does not decode is
        // a kind this build does not know, not damage.
        let record: Record =
            rmp_serde::from_slice(&self.payload).map_err(|e| LogError::UnknownRecord {
                path: self.path.clone(),
                offset: frame_offset,
                index: self.index,
                message: e.to_string(),
                crate_version: self.header.crate_version.clone(),
                git_commit: self.header.git_commit.clone(),
            })?;
        self.chain = chain;
        self.offset += FRAME_OVERHEAD + u64::from(len);
        if let Record::Checkpoint(c) = &record {
            self.last_checkpoint = Some(GoodCheckpoint {
                index: self.index,
                time: c.time,
            });
        }
        self.index += 1;
        Ok(Some(record))
    }

    /// The raw payload of the record last returned (its exact encoded bytes).
    pub fn last_payload(&self) -> &[u8] {
        &self.payload
    }
}

/// Where a reader stands between two frames of a log: what [`LogReader::seek_to`] needs to read
/// on from there without reading the frames before (their chain value is kept in it).
#[derive(Clone, Debug)]
pub struct Position {
    offset: u64,
    index: u64,
    chain: HashChain,
    last_checkpoint: Option<GoodCheckpoint>,
}

impl Position {
    /// Index of the next record.
    pub fn index(&self) -> u64 {
        self.index
    }
}

impl<R: Read> LogReader<R> {
    /// Where the reader stands (before the next frame).
    pub fn position(&self) -> Position {
        Position {
            offset: self.offset,
            index: self.index,
            chain: self.chain.clone(),
            last_checkpoint: self.last_checkpoint,
        }
    }
}

impl<R: Read + Seek> LogReader<R> {
    /// Moves the reader to `position`, taken earlier from a reader of this same file, to read
    /// on from there. Every frame after it is checked as in one read from the start (the chain
    /// goes on from the value kept in `position`), so a file that changed after the position
    /// was taken reads as corrupt there.
    pub fn seek_to(&mut self, position: &Position) -> Result<(), LogError> {
        self.input
            .seek(SeekFrom::Start(position.offset))
            .map_err(|e| LogError::Io {
                path: self.path.clone(),
                message: e.to_string(),
            })?;
        self.offset = position.offset;
        self.index = position.index;
        self.chain = position.chain.clone();
        self.last_checkpoint = position.last_checkpoint;
        self.footer = None;
        Ok(())
    }
}

/// What [`LogReader::next_intact`] found at the reader's place in a log that may still grow.
#[derive(Debug)]
pub enum Next {
    /// The next record, verified.
    Record(Record),
    /// The verified footer: the log is complete ([`LogReader::footer`] has it).
    End,
    /// The file ends inside the next frame (or before it, without a footer): a writer may be
    /// writing it. The reader stands at that frame's start, and a later call reads it once
    /// the file holds it; the error is what a reader of the file as it is now reports.
    Pending(LogError),
}

impl<R: Read + Seek> LogReader<R> {
    /// Reads the next record of a log that may still be growing (`swarmfl run --live` reads
    /// the log its run is writing): only the bytes after the records already read, and a
    /// frame the file ends inside is [`Next::Pending`], not an error; a damaged frame still
    /// is ([`LogError::Corrupt`]). Pending leaves the reader as it was before the call (its
    /// offset, index, chain and last checkpoint; not [`LogReader::last_payload`]), so the
    /// records read across any number of calls are those of one read of the finished file.
    pub fn next_intact(&mut self) -> Result<Next, LogError> {
        match self.next_record() {
            Ok(Some(record)) => Ok(Next::Record(record)),
            Ok(None) => Ok(Next::End),
            Err(cut @ LogError::Truncated { .. }) => {
                // A cut frame changes nothing of the reader's but how far its input went.
                self.input
                    .seek(SeekFrom::Start(self.offset))
                    .map_err(|e| LogError::Io {
                        path: self.path.clone(),
                        message: e.to_string(),
                    })?;
                Ok(Next::Pending(cut))
            }
            Err(e) => Err(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event::{Checkpoint, CheckpointCause, Event};
    use crate::world::{TickEvent, WheelCommand};

    fn sample_log(records: u64) -> (Vec<u8>, Footer) {
        let header = Header::new(7, "preset = \"smoke\"\n".to_string());
        let mut w = LogWriter::new(Vec::new(), "mem", &header).unwrap();
        for i in 0..records {
            let record = if i % 10 == 9 {
                Record::Checkpoint(Checkpoint {
                    time: SimTime(i * 100),
                    cause: CheckpointCause::Periodic,
                    world: Digest::of(&i.to_le_bytes()),
                    nodes: vec![],
                    contract: Digest::default(),
                    metrics: Digest::default(),
                    aggregation: None,
                    params: Digest::default(),
                })
            } else {
                Record::Event {
                    time: SimTime(i * 100),
                    event: Event::Tick(TickEvent {
                        commands: vec![
                            WheelCommand {
                                left_mmps: i as i16,
                                right_mmps: 25
                            };
                            3
                        ],
                    }),
                }
            };
            w.append(&record).unwrap();
        }
        let (footer, out) = w.finish().unwrap();
        (out, footer)
    }

    fn read_all(bytes: &[u8]) -> (Vec<Record>, Result<Footer, LogError>) {
        let mut reader = match LogReader::new(bytes, "mem") {
            Ok(r) => r,
            Err(e) => return (vec![], Err(e)),
        };
        let mut records = vec![];
        loop {
            match reader.next_record() {
                Ok(Some(r)) => records.push(r),
                Ok(None) => return (records, Ok(reader.footer().unwrap())),
                Err(e) => return (records, Err(e)),
            }
        }
    }

    #[test]
    fn header_and_records_round_trip() {
        let (bytes, footer) = sample_log(25);
        let reader = LogReader::new(&bytes[..], "mem").unwrap();
        assert_eq!(reader.header().seed, 7);
        assert_eq!(reader.header().config_toml, "preset = \"smoke\"\n");
        assert_eq!(reader.header().format_version, FORMAT_VERSION);
        let (records, end) = read_all(&bytes);
        assert_eq!(records.len(), 25);
        assert_eq!(end.unwrap(), footer);
        let mut reader = LogReader::new(&bytes[..], "mem").unwrap();
        while reader.next_record().unwrap().is_some() {}
        assert_eq!(reader.chain_hash(), footer.final_hash, "after the footer");
        assert_eq!(records[9].kind(), "checkpoint");
        assert_eq!(records[3].time(), SimTime(300));
    }

    #[test]
    fn the_hash_chain_names_the_run() {
        let (a, fa) = sample_log(25);
        let (b, fb) = sample_log(25);
        assert_eq!(a, b, "same records, same bytes");
        assert_eq!(fa.final_hash, fb.final_hash);
        let (_, fc) = sample_log(24);
        assert_ne!(fa.final_hash, fc.final_hash);
    }

    #[test]
    fn every_single_byte_flip_is_caught_at_its_record() {
        let (bytes, _) = sample_log(25);
        let header_end = {
            let r = LogReader::new(&bytes[..], "mem").unwrap();
            r.offset() as usize
        };
        for pos in 16..header_end {
            let mut damaged = bytes.clone();
            damaged[pos] ^= 0x01;
            let err = read_all(&damaged).1.unwrap_err();
            assert!(
                matches!(err, LogError::Header { .. }),
                "flip at {pos}: {err}"
            );
        }
        for pos in (header_end..bytes.len()).step_by(7) {
            let mut damaged = bytes.clone();
            damaged[pos] ^= 0x10;
            let (records, end) = read_all(&damaged);
            let err = end.expect_err("a flipped byte must be detected");
            let offset = err.offset().expect("offset reported") as usize;
            assert!(offset <= pos, "damage at {pos} reported at {offset}");
            assert_eq!(err.record_index(), Some(records.len() as u64), "{err}");
            assert!(
                matches!(err, LogError::Corrupt { .. }),
                "flip at {pos}: {err}"
            );
        }
    }

    /// The byte offset of every frame of a log (records and footer).
    fn frame_offsets(bytes: &[u8]) -> Vec<usize> {
        let mut at = LogReader::new(bytes, "mem").unwrap().offset() as usize;
        let mut frames = vec![];
        while at < bytes.len() {
            frames.push(at);
            let len = u32::from_le_bytes(bytes[at + 1..at + 5].try_into().unwrap());
            at += FRAME_OVERHEAD as usize + len as usize;
        }
        frames
    }

    #[test]
    fn a_damaged_frame_length_is_corruption_at_its_record_not_a_cut() {
        let (bytes, _) = sample_log(25);
        let frames = frame_offsets(&bytes);
        assert_eq!(frames.len(), 26, "25 records and the footer");
        for (index, &frame) in frames.iter().enumerate() {
            // Every bit of the length field and of the kind: a larger length used to read
            // past the end of the file and be reported as a truncated log.
            for pos in frame..frame + 5 {
                for bit in 0..8 {
                    let mut damaged = bytes.clone();
                    damaged[pos] ^= 1 << bit;
                    let (records, end) = read_all(&damaged);
                    let err = end.expect_err("a damaged frame header must be detected");
                    assert!(
                        matches!(err, LogError::Corrupt { .. }),
                        "byte {pos} bit {bit}: {err}"
                    );
                    assert_eq!(err.offset(), Some(frame as u64), "{err}");
                    assert_eq!(records.len(), index, "{err}");
                    assert!(err.to_string().contains("corrupt record"), "{err}");
                }
            }
        }
    }

    /// The bytes of a version-1 log of `records` (the layout of the fixtures committed before
    /// version 2): an 8-byte tag per frame and no frame check.
    fn version_1_log(records: &[Record]) -> Vec<u8> {
        let mut header = Header::new(7, "preset = \"smoke\"\n".to_string());
        header.format_version = 1;
        let header_bytes = rmp_serde::to_vec_named(&header).unwrap();
        let mut out = MAGIC.to_vec();
        out.extend_from_slice(&1u32.to_le_bytes());
        out.extend_from_slice(&(header_bytes.len() as u32).to_le_bytes());
        out.extend_from_slice(&header_bytes);
        out.extend_from_slice(&blake3::hash(&header_bytes).as_bytes()[..8]);
        let mut chain = HashChain::start(&header);
        let frame = |out: &mut Vec<u8>, chain: &mut HashChain, kind: u8, payload: &[u8]| {
            out.push(kind);
            out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
            out.extend_from_slice(&chain.fold(payload));
            out.extend_from_slice(payload);
        };
        let mut buf = vec![];
        for r in records {
            encode_record(r, &mut buf);
            frame(&mut out, &mut chain, KIND_RECORD, &buf);
        }
        let footer = Footer {
            records: records.len() as u64,
            final_hash: chain.digest(),
        };
        let footer = rmp_serde::to_vec(&footer).unwrap();
        frame(&mut out, &mut chain, KIND_FOOTER, &footer);
        out
    }

    #[test]
    fn a_reader_moved_to_a_kept_position_reads_on_as_one_read_of_the_whole() {
        let (bytes, footer) = sample_log(25);
        let (whole, _) = read_all(&bytes);
        let mut reader = LogReader::new(std::io::Cursor::new(&bytes), "mem").unwrap();
        for _ in 0..12 {
            reader.next_record().unwrap();
        }
        let at_12 = reader.position();
        assert_eq!(at_12.index(), 12);
        while reader.next_record().unwrap().is_some() {}
        reader.seek_to(&at_12).unwrap();
        let mut rest = vec![];
        while let Some(r) = reader.next_record().unwrap() {
            rest.push(r);
        }
        assert_eq!(rest, whole[12..]);
        assert_eq!(reader.footer(), Some(footer));
        // A position of another log (the same records under another seed) does not fit this
        // file: its next frame is corrupt.
        let header = Header::new(8, "preset = \"smoke\"\n".to_string());
        let mut w = LogWriter::new(Vec::new(), "mem", &header).unwrap();
        for r in &whole {
            w.append(r).unwrap();
        }
        let (_, other) = w.finish().unwrap();
        assert_eq!(
            other.len(),
            bytes.len(),
            "the frames stand at the same offsets"
        );
        let mut reader = LogReader::new(std::io::Cursor::new(&other), "mem").unwrap();
        reader.seek_to(&at_12).unwrap();
        let err = reader.next_record().unwrap_err();
        assert!(matches!(err, LogError::Corrupt { index: 12, .. }), "{err}");
        assert!(
            err.to_string().contains("frame header check failed"),
            "{err}"
        );
    }

    #[test]
    fn version_1_logs_are_read_with_the_same_chain_and_size() {
        let (v2, footer) = sample_log(25);
        let (records, _) = read_all(&v2);
        let v1 = version_1_log(&records);
        assert_eq!(v1.len(), v2.len(), "the layouts have frames of one size");
        assert_ne!(v1, v2);
        let reader = LogReader::new(&v1[..], "v1").unwrap();
        assert_eq!(reader.format_version(), 1);
        assert_eq!(reader.header().format_version, 1);
        let (again, end) = read_all(&v1);
        assert_eq!(again, records);
        assert_eq!(end.unwrap(), footer, "the same final hash in both layouts");
        assert_eq!(
            LogReader::new(&v2[..], "v2").unwrap().format_version(),
            FORMAT_VERSION
        );
        // A version-1 frame is still checked by its 8-byte tag.
        let frames = frame_offsets(&v1);
        let mut damaged = v1.clone();
        damaged[frames[3] + FRAME_OVERHEAD as usize] ^= 0x04;
        let err = read_all(&damaged).1.unwrap_err();
        assert!(matches!(err, LogError::Corrupt { index: 3, .. }), "{err}");
    }

    #[test]
    fn a_cut_log_keeps_its_prefix_and_names_the_last_checkpoint() {
        let (bytes, _) = sample_log(25);
        for cut in [bytes.len() - 1, bytes.len() - 40, bytes.len() / 2] {
            let (records, end) = read_all(&bytes[..cut]);
            let err = end.unwrap_err();
            let message = err.to_string();
            assert!(matches!(err, LogError::Truncated { .. }), "{message}");
            assert!(message.contains("truncated at byte offset"), "{message}");
            assert!(
                message.contains(&format!("record {}", records.len())),
                "{message}"
            );
            if records.len() > 10 {
                assert!(
                    message.contains("last good checkpoint is record"),
                    "{message}"
                );
            }
        }
    }

    #[test]
    fn a_huge_length_on_a_short_file_fails_without_allocating_it() {
        let (bytes, _) = sample_log(3);
        let header_end = LogReader::new(&bytes[..], "mem").unwrap().offset() as usize;
        let mut damaged = bytes[..header_end + 13].to_vec();
        // A frame header that checks (the file is cut, not altered): the payload is missing.
        let check = LogReader::new(&bytes[..], "mem")
            .unwrap()
            .chain
            .frame_check(KIND_RECORD, MAX_PAYLOAD_BYTES);
        damaged[header_end + 1..header_end + 5].copy_from_slice(&MAX_PAYLOAD_BYTES.to_le_bytes());
        damaged[header_end + 5..header_end + 9].copy_from_slice(&check);
        let mut reader = LogReader::new(&damaged[..], "mem").unwrap();
        let err = reader.next_record().unwrap_err();
        assert!(matches!(err, LogError::Truncated { index: 0, .. }), "{err}");
        assert!(
            err.to_string().contains("(0 of 268435456 payload bytes)"),
            "{err}"
        );
        assert!(
            reader.payload.capacity() < 1 << 20,
            "{}",
            reader.payload.capacity()
        );

        let mut header = bytes[..16].to_vec();
        header[12..16].copy_from_slice(&MAX_PAYLOAD_BYTES.to_le_bytes());
        header.extend_from_slice(&[0x90; 40]);
        let err = LogReader::new(&header[..], "mem")
            .err()
            .unwrap()
            .to_string();
        assert!(
            err.contains("ends inside the header (40 of 268435464 bytes)"),
            "{err}"
        );
    }

    #[test]
    fn an_intact_record_of_an_unknown_kind_names_the_writing_build() {
        let mut header = Header::new(1, String::new());
        header.crate_version = "9.9.9".to_string();
        header.git_commit = Some("abc123".to_string());
        let mut w = LogWriter::new(Vec::new(), "future.swlog", &header).unwrap();
        let tick = Record::Event {
            time: SimTime(0),
            event: Event::Tick(TickEvent { commands: vec![] }),
        };
        w.append(&tick).unwrap();
        // A record of a kind added by a later build: well-formed, chained, but unknown here.
        let unknown = rmp_serde::to_vec(&("Teleport", 7u8)).unwrap();
        w.write_frame(KIND_RECORD, &unknown).unwrap();
        w.records += 1;
        let (_, bytes) = w.finish().unwrap();
        let (records, end) = read_all(&bytes);
        assert_eq!(records.len(), 1);
        let err = end.unwrap_err();
        assert!(
            matches!(err, LogError::UnknownRecord { index: 1, .. }),
            "{err}"
        );
        let text = err.to_string();
        assert!(text.contains("swarmfl 9.9.9 (commit abc123)"), "{text}");
        assert!(text.contains("intact"), "{text}");
    }

    #[test]
    fn foreign_files_and_other_versions_are_named() {
        let (mut bytes, _) = sample_log(3);
        let err = read_all(b"hello world, not a log")
            .1
            .unwrap_err()
            .to_string();
        assert!(err.contains("not a swarmfl log"), "{err}");
        bytes[8] = 99;
        let err = read_all(&bytes).1.unwrap_err().to_string();
        assert!(
            err.contains("format version 99") && err.contains("reads versions 1 to 2"),
            "{err}"
        );
        let err = read_all(&MAGIC[..]).1.unwrap_err().to_string();
        assert!(err.contains("inside the fixed header"), "{err}");
    }

    /// A file that a writer extends while it is read: the reader sees `visible` bytes of
    /// `bytes`, and a test shows it more.
    struct Growing {
        bytes: std::rc::Rc<std::cell::RefCell<(Vec<u8>, usize)>>,
        at: u64,
    }

    impl Read for Growing {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let shared = self.bytes.borrow();
            let (bytes, visible) = (&shared.0, shared.1);
            let from = (self.at as usize).min(visible);
            let n = buf.len().min(visible - from);
            buf[..n].copy_from_slice(&bytes[from..from + n]);
            self.at += n as u64;
            Ok(n)
        }
    }

    impl Seek for Growing {
        fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
            let SeekFrom::Start(at) = to else {
                unreachable!("the reader seeks from the start only")
            };
            self.at = at;
            Ok(at)
        }
    }

    /// Reads a log shown `cuts` bytes at a time (then whole) with [`LogReader::next_intact`]:
    /// the records, the end, and the pending errors met on the way.
    fn read_growing(bytes: &[u8], cuts: &[usize]) -> (Vec<Record>, Result<Footer, LogError>) {
        let shared = std::rc::Rc::new(std::cell::RefCell::new((bytes.to_vec(), cuts[0])));
        let input = BufReader::with_capacity(
            16,
            Growing {
                bytes: std::rc::Rc::clone(&shared),
                at: 0,
            },
        );
        let mut reader = LogReader::new(input, "mem").unwrap();
        let mut records = vec![];
        for &visible in cuts.iter().chain([&bytes.len()]) {
            shared.borrow_mut().1 = visible;
            loop {
                match reader.next_intact() {
                    Ok(Next::Record(r)) => records.push(r),
                    Ok(Next::End) => return (records, Ok(reader.footer().unwrap())),
                    Ok(Next::Pending(e)) => {
                        let at = shared.borrow().1;
                        assert!(at < bytes.len(), "pending only before the end: {e}");
                        // What a reader of the file as it is now says.
                        let (_, now) = read_all(&bytes[..at]);
                        assert_eq!(now.unwrap_err().to_string(), e.to_string());
                        break;
                    }
                    Err(e) => return (records, Err(e)),
                }
            }
        }
        (
            records,
            Err(reader.truncated(reader.offset(), "pending".into())),
        )
    }

    #[test]
    fn a_growing_log_is_read_in_pieces_as_one_read_of_the_whole() {
        let (bytes, footer) = sample_log(25);
        let (whole, _) = read_all(&bytes);
        let header_end = 24 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        // Cuts inside frame headers, payloads, at frame boundaries and inside the footer.
        let n = bytes.len();
        for step in [1, 5, 13, 37, 200] {
            let cuts: Vec<usize> = (header_end + 8..n).step_by(step).collect();
            let (records, end) = read_growing(&bytes, &cuts);
            assert_eq!(records, whole, "step {step}");
            assert_eq!(end.unwrap(), footer, "step {step}");
        }
        for cuts in [
            vec![n - 1],
            vec![header_end + 8, n - 2],
            vec![n / 2, n / 2 + 1],
        ] {
            let (records, end) = read_growing(&bytes, &cuts);
            assert_eq!(records, whole, "{cuts:?}");
            assert_eq!(end.unwrap(), footer, "{cuts:?}");
        }
    }

    #[test]
    fn a_growing_log_with_a_damaged_record_is_still_refused() {
        let (mut bytes, _) = sample_log(25);
        let (whole, _) = read_all(&bytes);
        // A payload byte of a record in the second half: the cut before it is pending, the
        // damage after it an error at that record.
        let n = bytes.len();
        let mut frame = 24 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        while frame < n * 3 / 4 {
            let len = u32::from_le_bytes(bytes[frame + 1..frame + 5].try_into().unwrap());
            frame += FRAME_OVERHEAD as usize + len as usize;
        }
        bytes[frame + FRAME_OVERHEAD as usize + 1] ^= 0x10;
        let (records, end) = read_growing(&bytes, &[n / 2, n / 2 + 3]);
        let err = end.unwrap_err();
        assert!(matches!(err, LogError::Corrupt { .. }), "{err}");
        assert_eq!(err.record_index(), Some(records.len() as u64));
        assert!(records.len() < whole.len() && records[..] == whole[..records.len()]);
    }
}

//! [`LogReader`]: reads a log as a stream, checking each frame's header and tag before its
//! record is returned; the positions it can go back to; its reading of a log still being
//! written.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use super::{
    Footer, GoodCheckpoint, HashChain, Header, LogError, FORMAT_VERSION, FRAME_OVERHEAD,
    KIND_FOOTER, KIND_RECORD, MAGIC, MAX_PAYLOAD_BYTES, OLDEST_FORMAT_VERSION,
};
use crate::event::Record;
use crate::types::Digest;

/// Reads a log as a stream, verifying the hash chain at every frame.
pub struct LogReader<R: Read> {
    input: R,
    path: String,
    /// The file's layout version ([`OLDEST_FORMAT_VERSION`] to [`FORMAT_VERSION`]).
    version: u32,
    header: Header,
    header_bytes: Vec<u8>,
    /// The chain up to the last frame read (the log's tests read it too).
    pub(super) chain: HashChain,
    offset: u64,
    index: u64,
    last_checkpoint: Option<GoodCheckpoint>,
    footer: Option<Footer>,
    /// The payload last read (the log's tests check that it grows with the bytes read).
    pub(super) payload: Vec<u8>,
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

    /// The log ends early at `offset` (the frame being read): the error names the records
    /// read and the last good checkpoint.
    pub(super) fn truncated(&self, offset: u64, message: String) -> LogError {
        LogError::Truncated {
            path: self.path.clone(),
            offset,
            index: self.index,
            message,
            last_good_checkpoint: self.last_checkpoint,
        }
    }

    /// The frame at `offset` is damaged: the error names the records read and the last good
    /// checkpoint.
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
        let (head, kind, len) = self.read_frame_head(frame_offset)?;
        let chain = self.read_payload(frame_offset, &head, len)?;
        if kind == KIND_FOOTER {
            self.end_at_footer(frame_offset, len)?;
            return Ok(None);
        }
        self.take_record(frame_offset, len, chain).map(Some)
    }

    /// Reads the header of the frame at `frame_offset` and checks its kind, its header check
    /// (version 2) and its length, before any payload byte is read: (header, kind, length).
    fn read_frame_head(
        &mut self,
        frame_offset: u64,
    ) -> Result<([u8; FRAME_OVERHEAD as usize], u8, u32), LogError> {
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
        Ok((head, kind, len))
    }

    /// Reads the `len` payload bytes of the frame at `frame_offset` (header `head`) into
    /// `self.payload` and checks its tag: the hash chain with the payload folded in.
    fn read_payload(
        &mut self,
        frame_offset: u64,
        head: &[u8; FRAME_OVERHEAD as usize],
        len: u32,
    ) -> Result<HashChain, LogError> {
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
        Ok(chain)
    }

    /// The payload is the footer (of `len` bytes, at `frame_offset`): checks it against the
    /// records read and that nothing follows it, then ends the log there.
    fn end_at_footer(&mut self, frame_offset: u64, len: u32) -> Result<(), LogError> {
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
        Ok(())
    }

    /// The payload is a record (of `len` bytes, at `frame_offset`) whose tag verified:
    /// decodes it and moves the reader past it, to the hash chain `chain` that folds it.
    fn take_record(
        &mut self,
        frame_offset: u64,
        len: u32,
        chain: HashChain,
    ) -> Result<Record, LogError> {
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
        Ok(record)
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

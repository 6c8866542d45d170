#![no_main]
//! Fuzzes the log reader. The first input byte picks one of three modes:
//!
//! - raw: the bytes are a log file;
//! - resealed: the bytes are a log file whose header tag and frame tags are recomputed before
//!   reading, so that the fuzzer reaches the header, record and footer decoders behind the
//!   checksums;
//! - damaged: a valid log is written from the bytes, then bit flips, byte writes and cuts taken
//!   from the bytes damage it; the reader must detect the damage and every record it returned
//!   before must equal the one written.
//!
//! In every mode the reader must not panic, must stop (every frame takes at least 13 bytes), and
//! must not allocate more than the bytes it is given (libFuzzer's `-rss_limit_mb` catches that).

use libfuzzer_sys::fuzz_target;
use swarmfl_core::event::{Checkpoint, CheckpointCause, Record};
use swarmfl_core::log::{HashChain, Header, LogError, LogReader, LogWriter, FORMAT_VERSION, MAGIC};
use swarmfl_core::types::{Digest, SimTime};

const FRAME_OVERHEAD: usize = 13;

fn read_all(bytes: &[u8]) -> (Vec<Record>, Option<LogError>) {
    let mut reader = match LogReader::new(bytes, "fuzz") {
        Ok(r) => r,
        Err(e) => return (Vec::new(), Some(e)),
    };
    let mut records = Vec::new();
    for _ in 0..=bytes.len() / FRAME_OVERHEAD + 1 {
        match reader.next_record() {
            Ok(Some(r)) => records.push(r),
            Ok(None) => {
                assert!(reader.footer().is_some(), "Ok(None) without a footer");
                assert!(reader.next_record().unwrap().is_none());
                return (records, None);
            }
            Err(e) => {
                let message = e.to_string();
                assert!(
                    message.starts_with("fuzz"),
                    "error does not name the file: {message}"
                );
                if let Some(index) = e.record_index() {
                    assert_eq!(index, records.len() as u64, "{message}");
                }
                return (records, Some(e));
            }
        }
    }
    panic!(
        "the reader returned more frames than {} bytes can hold",
        bytes.len()
    );
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
}

/// Recomputes the header tag and every frame's tag, clamping lengths to the bytes present.
fn reseal(data: &[u8]) -> Vec<u8> {
    let mut out = data.to_vec();
    if out.len() < 24 {
        return out;
    }
    out[..8].copy_from_slice(MAGIC);
    out[8..12].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    let header_len = (u32_at(&out, 12) as usize).min(out.len() - 24);
    out[12..16].copy_from_slice(&(header_len as u32).to_le_bytes());
    let header_bytes = out[16..16 + header_len].to_vec();
    out[16 + header_len..24 + header_len]
        .copy_from_slice(&blake3::hash(&header_bytes).as_bytes()[..8]);
    let header: Header = match rmp_serde::from_slice(&header_bytes) {
        Ok(h) => h,
        Err(_) => return out,
    };
    let mut chain = HashChain::start(&header);
    let mut pos = 24 + header_len;
    while pos + FRAME_OVERHEAD <= out.len() {
        let len = (u32_at(&out, pos + 1) as usize).min(out.len() - pos - FRAME_OVERHEAD);
        out[pos + 1..pos + 5].copy_from_slice(&(len as u32).to_le_bytes());
        let start = pos + FRAME_OVERHEAD;
        let check = chain.frame_check(out[pos], len as u32);
        let tag = chain.fold(&out[start..start + len]);
        out[pos + 5..pos + 9].copy_from_slice(&check);
        out[pos + 9..pos + 13].copy_from_slice(&tag[..4]);
        pos = start + len;
    }
    out
}

/// Takes bytes from the front of the input, zeros once it is used up.
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        match self.0.split_first() {
            Some((&b, rest)) => {
                self.0 = rest;
                b
            }
            None => 0,
        }
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }
    fn u64(&mut self) -> u64 {
        let mut b = [0u8; 8];
        for x in &mut b {
            *x = self.u8();
        }
        u64::from_le_bytes(b)
    }
}

fn damaged(data: &[u8]) {
    let mut input = Bytes(data);
    let header = Header::new(
        input.u64(),
        format!("preset = \"smoke\"\nrun = {}\n", input.u8()),
    );
    let mut writer = LogWriter::new(Vec::new(), "fuzz", &header).expect("writes to memory");
    let mut written = Vec::new();
    for _ in 0..input.u8() % 24 {
        let flags = input.u8();
        let record = Record::Checkpoint(Checkpoint {
            time: SimTime(u64::from(input.u16()) * 50),
            cause: match flags % 3 {
                0 => CheckpointCause::Block {
                    node: u32::from(input.u8()),
                    height: u64::from(input.u8()),
                },
                1 => CheckpointCause::Periodic,
                _ => CheckpointCause::End,
            },
            world: Digest::of(&[input.u8()]),
            nodes: (0..flags / 64)
                .map(|i| Digest::of(&[i, input.u8()]))
                .collect(),
            contract: Digest::of(&[input.u8(), 1]),
            metrics: Digest::default(),
            params: Digest::default(),
            // Present in baseline (stigmergy, central) runs, absent in chain runs.
            aggregation: (flags & 0x20 != 0).then(|| Digest::of(&[input.u8(), 2])),
        });
        writer.append(&record).expect("writes to memory");
        written.push(record);
    }
    let (footer, bytes) = writer.finish().expect("writes to memory");
    let (records, err) = read_all(&bytes);
    assert!(err.is_none(), "an intact log fails: {err:?}");
    assert_eq!(
        records, written,
        "an intact log reads back different records"
    );
    assert_eq!(footer.records, written.len() as u64);

    let mut damaged = bytes.clone();
    while !input.0.is_empty() && !damaged.is_empty() {
        let op = input.u8();
        let pos = usize::from(input.u16()) % damaged.len();
        match op % 3 {
            0 => damaged[pos] ^= 1 << (op / 3 % 8),
            1 => damaged[pos] = input.u8(),
            _ => damaged.truncate(pos),
        }
    }
    if damaged == bytes {
        return;
    }
    let (records, err) = read_all(&damaged);
    let err = err.expect("a damaged log was read without an error");
    assert!(
        records.len() <= written.len() && records[..] == written[..records.len()],
        "a damaged log returned a record that was not written ({err})"
    );
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    match mode % 3 {
        0 => {
            read_all(rest);
        }
        1 => {
            read_all(&reseal(rest));
        }
        _ => damaged(rest),
    }
});

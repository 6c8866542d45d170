//! The log format's tests: round trips, every damage caught at its record, version 1, cut
//! and growing logs.

use std::io::{BufReader, Read, Seek, SeekFrom};

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

//! Property tests of the run log: random record sequences round-trip exactly (same records, same
//! final hash); every cut and every bit flip is detected, never a panic, and every record read
//! before the reported damage is the one written.

use proptest::prelude::*;
use swarmfl_core::event::{Checkpoint, CheckpointCause, Event, Reconfiguration, Record};
use swarmfl_core::log::{Footer, ForkOrigin, Header, LogError, LogReader, LogWriter};
use swarmfl_core::types::{Digest, SimTime};
use swarmfl_core::world::{TickEvent, WheelCommand};

/// What a generated record is; [`record`] builds it, so a change to the record types is adapted
/// in one place.
#[derive(Clone, Debug)]
enum Spec {
    Checkpoint {
        time_ms: u64,
        cause: u8,
        node: u32,
        height: u64,
        nodes: u8,
        salt: u64,
    },
    Tick {
        time_ms: u64,
        commands: Vec<(i16, i16)>,
    },
    Reconfigure {
        at_ms: u64,
        overrides: Vec<String>,
        config_toml: String,
    },
}

fn record(spec: &Spec) -> Record {
    match spec {
        Spec::Checkpoint {
            time_ms,
            cause,
            node,
            height,
            nodes,
            salt,
        } => Record::Checkpoint(Checkpoint {
            time: SimTime(*time_ms),
            cause: match cause % 4 {
                0 => CheckpointCause::Block {
                    node: *node,
                    height: *height,
                },
                1 => CheckpointCause::Periodic,
                2 => CheckpointCause::Reconfigure,
                _ => CheckpointCause::End,
            },
            world: Digest::of(&salt.to_le_bytes()),
            nodes: (0..*nodes).map(|i| Digest::of(&[i])).collect(),
            contract: Digest::of(&time_ms.to_le_bytes()),
            metrics: Digest::default(),
            aggregation: None,
            params: Digest::default(),
        }),
        Spec::Tick { time_ms, commands } => Record::Event {
            time: SimTime(*time_ms),
            event: Event::Tick(TickEvent {
                commands: commands
                    .iter()
                    .map(|&(left_mmps, right_mmps)| WheelCommand {
                        left_mmps,
                        right_mmps,
                    })
                    .collect(),
            }),
        },
        Spec::Reconfigure {
            at_ms,
            overrides,
            config_toml,
        } => Record::Event {
            time: SimTime(*at_ms),
            event: Event::Reconfigure(Reconfiguration {
                at_ms: *at_ms,
                overrides: overrides.clone(),
                config_toml: config_toml.clone(),
            }),
        },
    }
}

fn spec() -> impl Strategy<Value = Spec> {
    prop_oneof![
        3 => (any::<u64>(), any::<u8>(), any::<u32>(), any::<u64>(), 0u8..20, any::<u64>()).prop_map(
            |(time_ms, cause, node, height, nodes, salt)| Spec::Checkpoint {
                time_ms,
                cause,
                node,
                height,
                nodes,
                salt,
            }
        ),
        1 => (any::<u64>(), prop::collection::vec((any::<i16>(), any::<i16>()), 0..20))
            .prop_map(|(time_ms, commands)| Spec::Tick { time_ms, commands }),
        1 => (any::<u64>(), prop::collection::vec(".{0,20}", 0..3), ".{0,80}").prop_map(
            |(at_ms, overrides, config_toml)| Spec::Reconfigure { at_ms, overrides, config_toml }
        ),
    ]
}

fn header() -> impl Strategy<Value = Header> {
    (
        any::<u64>(),
        ".{0,200}",
        prop::option::of((
            any::<[u8; 32]>(),
            any::<u64>(),
            prop::collection::vec(".{0,20}", 0..3),
            prop::collection::vec((any::<u64>(), ".{0,60}"), 0..3),
        )),
    )
        .prop_map(|(seed, config_toml, parent)| {
            let mut header = Header::new(seed, config_toml);
            header.parent = parent.map(|(hash, height, overrides, changes)| ForkOrigin {
                parent_final_hash: Digest(hash),
                height,
                overrides: overrides.clone(),
                reconfigurations: changes
                    .into_iter()
                    .map(|(at_ms, config_toml)| Reconfiguration {
                        at_ms,
                        overrides: overrides.clone(),
                        config_toml,
                    })
                    .collect(),
            });
            header
        })
}

struct Written {
    bytes: Vec<u8>,
    records: Vec<Record>,
    footer: Footer,
    /// Byte offset of the first frame.
    header_end: usize,
}

fn write(header: &Header, specs: &[Spec]) -> Written {
    let mut writer = LogWriter::new(Vec::new(), "mem", header).expect("writes to memory");
    let header_end = writer.bytes() as usize;
    let records: Vec<Record> = specs.iter().map(record).collect();
    for r in &records {
        writer.append(r).expect("writes to memory");
    }
    let chain = writer.chain_hash();
    let (footer, bytes) = writer.finish().expect("writes to memory");
    assert_eq!(footer.final_hash, chain);
    Written {
        bytes,
        records,
        footer,
        header_end,
    }
}

/// Reads every record; the error (if any) and the footer (if complete). Fails the test if the
/// reader returns more frames than the bytes can hold (it would loop).
fn read_all(bytes: &[u8]) -> (Vec<Record>, Result<Footer, LogError>) {
    let mut reader = match LogReader::new(bytes, "mem") {
        Ok(r) => r,
        Err(e) => return (vec![], Err(e)),
    };
    let mut records = vec![];
    for _ in 0..=bytes.len() / 13 + 1 {
        match reader.next_record() {
            Ok(Some(r)) => records.push(r),
            Ok(None) => {
                let footer = reader.footer().expect("Ok(None) comes with a footer");
                assert_eq!(reader.chain_hash(), footer.final_hash);
                return (records, Ok(footer));
            }
            Err(e) => return (records, Err(e)),
        }
    }
    panic!(
        "the reader returned more frames than {} bytes hold",
        bytes.len()
    );
}

/// The records read before an error are the first ones written, and the error's record index
/// is the count read.
fn check_prefix(read: &[Record], written: &[Record], err: &LogError) {
    assert!(read.len() <= written.len(), "{err}");
    assert_eq!(read, &written[..read.len()], "{err}");
    if let Some(index) = err.record_index() {
        assert_eq!(index, read.len() as u64, "{err}");
    }
    assert!(err.to_string().starts_with("mem: "), "{err}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_logs_round_trip(header in header(), specs in prop::collection::vec(spec(), 0..40)) {
        let w = write(&header, &specs);
        let reader = LogReader::new(&w.bytes[..], "mem").unwrap();
        prop_assert_eq!(reader.header(), &header);
        prop_assert_eq!(reader.offset() as usize, w.header_end);
        let (records, end) = read_all(&w.bytes);
        prop_assert_eq!(&records, &w.records);
        prop_assert_eq!(end.unwrap(), w.footer);
        // The same run written again is the same bytes; one record less is another hash.
        prop_assert_eq!(&write(&header, &specs).bytes, &w.bytes);
        if !specs.is_empty() {
            let shorter = write(&header, &specs[..specs.len() - 1]);
            prop_assert_ne!(shorter.footer.final_hash, w.footer.final_hash);
        }
    }

    #[test]
    fn every_cut_is_detected_at_or_before_it(
        header in header(),
        specs in prop::collection::vec(spec(), 0..30),
        at in 0.0f64..1.0,
    ) {
        let w = write(&header, &specs);
        let cut = (at * w.bytes.len() as f64) as usize;
        let (records, end) = read_all(&w.bytes[..cut]);
        let err = end.expect_err("a cut log must not read as complete");
        check_prefix(&records, &w.records, &err);
        match &err {
            LogError::NotALog { .. } => prop_assert!(cut < 8, "{}", err),
            LogError::Header { .. } => prop_assert!(cut < w.header_end, "{}", err),
            LogError::Truncated { offset, .. } | LogError::Corrupt { offset, .. } => {
                prop_assert!(cut >= w.header_end, "{}", err);
                prop_assert!(*offset as usize <= cut, "cut at {} reported at {}", cut, err);
            }
            other => prop_assert!(false, "unexpected error for a cut: {}", other),
        }
    }

    #[test]
    fn every_bit_flip_is_detected(
        header in header(),
        specs in prop::collection::vec(spec(), 1..30),
        flips in prop::collection::vec((0.0f64..1.0, 0u8..8), 1..4),
    ) {
        let w = write(&header, &specs);
        let mut damaged = w.bytes.clone();
        let mut first = usize::MAX;
        for &(at, bit) in &flips {
            let pos = (at * damaged.len() as f64) as usize;
            damaged[pos] ^= 1 << bit;
            first = first.min(pos);
        }
        prop_assume!(damaged != w.bytes);
        let (records, end) = read_all(&damaged);
        let err = end.expect_err("a flipped bit must be detected");
        check_prefix(&records, &w.records, &err);
        match &err {
            LogError::NotALog { .. } | LogError::Version { .. } => prop_assert!(first < 16, "{}", err),
            LogError::Header { .. } => prop_assert!(first < w.header_end, "{}", err),
            LogError::Truncated { offset, .. } | LogError::Corrupt { offset, .. } => {
                prop_assert!(*offset as usize <= first.max(w.header_end), "flip at {} reported at {}", first, err);
            }
            LogError::Io { .. } => prop_assert!(false, "in-memory read fails with I/O: {}", err),
            LogError::UnknownRecord { .. } => prop_assert!(false, "a flipped bit passed the hash chain: {}", err),
        }
    }

    #[test]
    fn header_damage_is_reported_as_the_header(
        header in header(),
        specs in prop::collection::vec(spec(), 0..5),
        at in 0.0f64..1.0,
        byte in 1u8..=255,
    ) {
        let w = write(&header, &specs);
        let pos = (at * w.header_end as f64) as usize;
        let mut damaged = w.bytes.clone();
        damaged[pos] ^= byte;
        let (records, end) = read_all(&damaged);
        prop_assert!(records.is_empty());
        let err = end.expect_err("a damaged header must be detected");
        let expected = match pos {
            0..=7 => matches!(err, LogError::NotALog { .. }),
            8..=11 => matches!(err, LogError::Version { .. }),
            _ => matches!(err, LogError::Header { .. }),
        };
        prop_assert!(expected, "damage at {} reported as {}", pos, err);
    }
}

//! Altered logs, as the security review of issue #53 met them: a damaged frame length is
//! corruption for every command (the same exit code from `inspect` and `view`), and `replay`
//! without `--resimulate` does not claim more than it checked when a header was edited and its
//! chain recomputed.

use std::path::{Path, PathBuf};

use swarmfl_core::log::{Header, LogReader, LogWriter};

mod common;
use common::{scratch, swarmfl, text};

/// A 60 s smoke run of seed 7 into `out` (a few hundred records) with `extra` overrides; its
/// log's path.
fn short_run(out: &Path, extra: &[&str]) -> PathBuf {
    let mut args = vec![
        "run",
        "--preset",
        "smoke",
        "--seed",
        "7",
        "--quiet",
        "--set",
        "run.duration_s=60",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let run = swarmfl(&args);
    assert!(run.status.success(), "{}", text(&run.stderr));
    out.join("run.swlog")
}

/// The byte offset of frame `n` (record `n`) of a log.
fn frame_offset(bytes: &[u8], n: usize) -> usize {
    let header_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut at = 24 + header_len;
    for _ in 0..n {
        let len = u32::from_le_bytes(bytes[at + 1..at + 5].try_into().unwrap()) as usize;
        at += 13 + len;
    }
    at
}

#[test]
fn a_flipped_length_byte_is_corruption_with_one_exit_code_for_inspect_and_view() {
    let dir = scratch("length");
    let log = short_run(&dir.join("r"), &[]);
    let mut bytes = std::fs::read(&log).unwrap();
    // The length's third byte of record 10: 64 KiB more than the frame holds, which the rest
    // of the file still holds (a reader without a header check reads it and fails the tag),
    // and its fourth: 16 MiB more, past the end of the file (such a reader took it for a cut).
    for (byte, name) in [(3, "longer"), (4, "past-the-end")] {
        let at = frame_offset(&bytes, 10) + byte;
        bytes[at] ^= 0x01;
        let damaged = dir.join(format!("{name}.swlog"));
        std::fs::write(&damaged, &bytes).unwrap();
        bytes[at] ^= 0x01;
        let damaged = damaged.to_str().unwrap();
        let html = dir.join("v.html");
        let runs = [
            (
                "inspect",
                swarmfl(&["inspect", damaged, "--block", "0", "--no-index"]),
            ),
            (
                "view",
                swarmfl(&["view", damaged, "--out", html.to_str().unwrap()]),
            ),
            ("replay", swarmfl(&["replay", damaged])),
        ];
        for (command, out) in &runs {
            let err = text(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{command} on {name}: {err}");
            assert!(
                err.contains("corrupt record 10"),
                "{command} on {name}: {err}"
            );
            assert!(
                err.contains("frame header check failed"),
                "{command}: {err}"
            );
            assert!(!err.contains("truncated"), "{command} on {name}: {err}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_edited_header_with_a_recomputed_chain_is_consistent_but_not_bit_exact() {
    let dir = scratch("header");
    let log = short_run(&dir.join("r"), &["--set", "learn.learning_rate=0.01"]);
    // Re-write the log with another learning rate in its header: the writer recomputes the
    // chain, as anyone who edits a log can.
    let mut reader = LogReader::open(&log).unwrap();
    let mut header: Header = reader.header().clone();
    assert!(
        header.config_toml.contains("learning_rate = 0.01"),
        "{}",
        header.config_toml
    );
    header.config_toml = header
        .config_toml
        .replace("learning_rate = 0.01", "learning_rate = 0.02");
    let edited = dir.join("edited.swlog");
    let mut writer = LogWriter::create(&edited, &header).unwrap();
    while let Some(record) = reader.next_record().unwrap() {
        writer.append(&record).unwrap();
    }
    writer.finish().unwrap();
    let edited = edited.to_str().unwrap();

    let out = swarmfl(&["replay", edited]);
    let said = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!said.contains("bit-exact"), "{said}");
    assert!(
        said.contains("hash chain and checkpoints consistent"),
        "{said}"
    );
    assert!(said.contains("header not authenticated"), "{said}");
    assert!(said.contains("--resimulate"), "{said}");

    let out = swarmfl(&["replay", "--resimulate", edited]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stdout));
    assert!(
        text(&out.stderr).contains("diverged"),
        "{}",
        text(&out.stderr)
    );

    let out = swarmfl(&["replay", "--resimulate", log.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).starts_with("bit-exact: "),
        "{}",
        text(&out.stdout)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

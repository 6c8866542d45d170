//! Comparing two logs: what differs in their headers, and their first diverging record.

use std::path::Path;

use crate::config::Config;
use crate::event::Record;
use crate::log::LogReader;
use crate::replay::{describe_divergence, header_config, ReplayError};
use crate::types::{Digest, SimTime};

/// How two logs compare.
#[derive(Debug)]
pub struct DiffReport {
    /// Differences of the run identities: seed, configuration keys, fork origin.
    pub header_differences: Vec<String>,
    /// Records that are byte-identical before the first divergence.
    pub identical_records: u64,
    /// The first diverging record, if any.
    pub divergence: Option<Divergence>,
    /// Final hashes of the two logs.
    pub final_hashes: (Digest, Digest),
}

/// The first record at which two logs differ.
#[derive(Debug)]
pub struct Divergence {
    /// Record index (the same in both logs: all earlier records are identical).
    pub index: u64,
    /// Simulated time of the first log's record there (or of the second's if the first ended).
    pub time: SimTime,
    /// Byte offsets of the record in each log.
    pub offsets: (u64, u64),
    /// Record kinds in each log (`end` where a log has no more records).
    pub kinds: (&'static str, &'static str),
    /// The component that differs, and how.
    pub explanation: String,
}

/// Lists the configuration keys whose values differ, as `key: a -> b`.
pub fn config_differences(a: &Config, b: &Config) -> Vec<String> {
    let (va, vb) = (a.flat_values(), b.flat_values());
    a.changed_keys(b)
        .into_iter()
        .map(|key| {
            let show = |v: Option<&String>| v.cloned().unwrap_or_else(|| "(absent)".to_string());
            format!("{key}: {} -> {}", show(va.get(&key)), show(vb.get(&key)))
        })
        .collect()
}

/// Compares the logs at `a` and `b` record by record (the encoded bytes) and reports the
/// first divergence, naming the component that differs.
pub fn diff_logs(a: &Path, b: &Path) -> Result<DiffReport, ReplayError> {
    let (name_a, name_b) = (a.display().to_string(), b.display().to_string());
    let mut ra = LogReader::open(a)?;
    let mut rb = LogReader::open(b)?;
    let (ca, cb) = (header_config(&ra, &name_a)?, header_config(&rb, &name_b)?);
    let mut header_differences = Vec::new();
    if ra.header().seed != rb.header().seed {
        header_differences.push(format!(
            "seed: {} -> {}",
            ra.header().seed,
            rb.header().seed
        ));
    }
    header_differences.extend(config_differences(&ca, &cb));
    if ra.header().parent != rb.header().parent {
        header_differences.push(format!(
            "fork origin: {} -> {}",
            describe_origin(ra.header().parent.as_ref()),
            describe_origin(rb.header().parent.as_ref())
        ));
    }
    let mut identical = 0u64;
    loop {
        let (offset_a, offset_b) = (ra.offset(), rb.offset());
        let next_a = ra.next_record()?;
        let next_b = rb.next_record()?;
        match (next_a, next_b) {
            (None, None) => break,
            (Some(x), Some(y)) if ra.last_payload() == rb.last_payload() => {
                let _ = (x, y);
                identical += 1;
            }
            (x, y) => {
                let kinds = (
                    x.as_ref().map_or("end", Record::kind),
                    y.as_ref().map_or("end", Record::kind),
                );
                let time = x
                    .as_ref()
                    .or(y.as_ref())
                    .map(Record::time)
                    .unwrap_or_default();
                let explanation = match (&x, &y) {
                    (Some(x), Some(y)) => describe_divergence(&name_a, identical, x, y).to_string(),
                    _ => format!(
                        "{} ends after {identical} records while the other goes on",
                        if x.is_none() { &name_a } else { &name_b }
                    ),
                };
                return Ok(DiffReport {
                    header_differences,
                    identical_records: identical,
                    divergence: Some(Divergence {
                        index: identical,
                        time,
                        offsets: (offset_a, offset_b),
                        kinds,
                        explanation,
                    }),
                    final_hashes: (ra.chain_hash(), rb.chain_hash()),
                });
            }
        }
    }
    let fa = ra.footer().expect("finished").final_hash;
    let fb = rb.footer().expect("finished").final_hash;
    Ok(DiffReport {
        header_differences,
        identical_records: identical,
        divergence: None,
        final_hashes: (fa, fb),
    })
}

/// One line about where a run was forked from.
fn describe_origin(origin: Option<&crate::log::ForkOrigin>) -> String {
    let Some(o) = origin else {
        return "none (a root run)".to_string();
    };
    let changes: Vec<String> = o
        .reconfigurations
        .iter()
        .map(|r| format!("[{}] at t = {}", r.overrides.join(", "), SimTime(r.at_ms)))
        .collect();
    format!(
        "forked from {} at block {}; reconfigurations: {}",
        o.parent_final_hash,
        o.height,
        changes.join("; ")
    )
}

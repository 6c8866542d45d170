//! Regression fixtures: every log under `fixtures/logs` must replay bit-exactly through today's
//! reducers to the hashes in `fixtures/expected.toml`; the ones marked `resimulate` must also be
//! re-made record for record by today's driver. A failure names the first diverging record and
//! the component. After an intentional change: `swarmfl fixtures regenerate` and a CHANGELOG
//! line (see CHANGELOG.md).

use std::path::{Path, PathBuf};

use swarmfl_core::replay;

#[derive(serde::Deserialize)]
struct Expected {
    fixture: Vec<Fixture>,
}

#[derive(serde::Deserialize)]
struct Fixture {
    name: String,
    final_hash: String,
    records: u64,
    blocks: u64,
    resimulate: bool,
}

fn fixtures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures")
}

fn expected() -> Vec<Fixture> {
    let path = fixtures_dir().join("expected.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    toml::from_str::<Expected>(&text)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .fixture
}

const HINT: &str = "if this change of behaviour is intended, run \
    `cargo run --release -p replay-cli -- fixtures regenerate` and add a line to CHANGELOG.md";

fn check(
    fixture: &Fixture,
    report: Result<replay::ReplayReport, replay::ReplayError>,
    mode: &str,
) -> Option<String> {
    let report = match report {
        Ok(r) => r,
        Err(e) => return Some(format!("fixture {} ({mode}): {e}", fixture.name)),
    };
    let got = (report.final_hash.to_hex(), report.records, report.blocks);
    let want = (fixture.final_hash.clone(), fixture.records, fixture.blocks);
    (got != want).then(|| {
        format!(
            "fixture {} ({mode}): replays to (final hash, records, blocks) = {got:?}, expected {want:?}",
            fixture.name
        )
    })
}

#[test]
fn every_fixture_replays_bit_exactly() {
    let fixtures = expected();
    assert!(fixtures.len() >= 5, "the manifest lists the fixtures");
    let failures: Vec<String> = fixtures
        .iter()
        .filter_map(|f| {
            let log = fixtures_dir()
                .join("logs")
                .join(format!("{}.swlog", f.name));
            check(f, replay::replay(&log), "replay")
        })
        .collect();
    assert!(failures.is_empty(), "{}\n{HINT}", failures.join("\n"));
}

#[test]
fn short_fixtures_resimulate_bit_exactly() {
    let fixtures = expected();
    let marked: Vec<&Fixture> = fixtures.iter().filter(|f| f.resimulate).collect();
    assert!(!marked.is_empty(), "at least one fixture is re-simulated");
    let failures: Vec<String> = marked
        .iter()
        .filter_map(|f| {
            let log = fixtures_dir()
                .join("logs")
                .join(format!("{}.swlog", f.name));
            check(f, replay::resimulate(&log), "re-simulation")
        })
        .collect();
    assert!(failures.is_empty(), "{}\n{HINT}", failures.join("\n"));
}

#[test]
fn the_committed_fixtures_are_version_1_logs_and_still_read() {
    // The fixtures were written before format version 2 (the frame header check) and stay as
    // they are: they are how this build's reader of version 1 is tested on real runs.
    for f in expected() {
        let log = fixtures_dir()
            .join("logs")
            .join(format!("{}.swlog", f.name));
        let mut reader = swarmfl_core::log::LogReader::open(&log).unwrap();
        assert_eq!(reader.format_version(), 1, "{}", f.name);
        let mut records = 0u64;
        while reader.next_record().unwrap().is_some() {
            records += 1;
        }
        let footer = reader.footer().unwrap();
        assert_eq!(
            (footer.records, footer.final_hash.to_hex().to_string()),
            (records, f.final_hash.clone()),
            "{}",
            f.name
        );
    }
}

//! Blame's exactness, determinism and refusals, on short `smoke` runs.

use std::path::{Path, PathBuf};

use swarmfl_core::config::Config;
use swarmfl_core::event::Record;
use swarmfl_core::log::LogReader;

use super::world::Parent;
use super::*;
use crate::progress::Quiet;
use crate::run::RunRequest;

/// A fresh folder under the temporary directory.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("swarmfl-blame-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// A 250 s `smoke` run (two faulty robots) with `extra` overrides, written to `out`.
fn run(out: &Path, extra: &[&str]) -> PathBuf {
    let mut overrides = vec![
        "run.duration_s=250".to_string(),
        "byzantine.kind=faulty".to_string(),
        "byzantine.count=2".to_string(),
    ];
    overrides.extend(extra.iter().map(|s| s.to_string()));
    let config = Config::resolve(Some("smoke"), None, &overrides).expect("a valid configuration");
    RunRequest::new(config, 3, out)
        .run(&Quiet)
        .expect("the run");
    out.join("run.swlog")
}

/// The last checkpoint of a log.
fn last_checkpoint(log: &Path) -> Record {
    let mut reader = LogReader::open(log).expect("the log opens");
    let mut last = None;
    while let Some(record) = reader.next_record().expect("a record") {
        if matches!(record, Record::Checkpoint(_)) {
            last = Some(record);
        }
    }
    last.expect("a checkpoint")
}

/// The world's records (every tick's wheel commands) of a log.
fn ticks(log: &Path) -> Vec<Record> {
    let mut reader = LogReader::open(log).expect("the log opens");
    let mut out = Vec::new();
    while let Some(record) = reader.next_record().expect("a record") {
        if matches!(
            record,
            Record::Event {
                event: swarmfl_core::event::Event::Tick(_),
                ..
            }
        ) {
            out.push(record);
        }
    }
    out
}

/// The counterfactual without robot k is, bit for bit, the fresh run with
/// `learn.withheld = [k]`: the same outcome and the same last checkpoint (state digest), for
/// an honest and a Byzantine robot; and as if honest is the run with `byzantine.as_honest`.
#[test]
fn counterfactual_is_the_run_with_the_robot_withheld() {
    let base = dir("exact");
    let parent_log = run(&base.join("parent"), &[]);
    let expr = Expr::parse(DEFAULT_OUTCOME).expect("parses");
    let parent = Parent::load(&parent_log, &expr, &At::End).expect("loads");
    let byzantine = parent
        .byzantine
        .iter()
        .position(|&b| b)
        .expect("a Byzantine robot") as u32;
    let honest = parent
        .byzantine
        .iter()
        .position(|&b| !b)
        .expect("an honest robot") as u32;
    for (k, key) in [
        (honest, "learn.withheld"),
        (byzantine, "learn.withheld"),
        (byzantine, "byzantine.as_honest"),
    ] {
        let set = format!("{key}=[{k}]");
        let fresh_log = run(&base.join(format!("{key}-{k}")), &[set.as_str()]);
        let (withheld, as_honest): (&[u32], &[u32]) = if key == "learn.withheld" {
            (&[k], &[])
        } else {
            (&[], &[k])
        };
        let (outcome, last) = parent
            .counterfactual_run(withheld, as_honest)
            .expect("runs");
        let fresh = Parent::load(&fresh_log, &expr, &At::End).expect("loads");
        assert_eq!(outcome.to_bits(), fresh.outcome.to_bits(), "{set}: outcome");
        assert_eq!(
            last.as_ref(),
            Some(&last_checkpoint(&fresh_log)),
            "{set}: state"
        );
        assert_ne!(
            last_checkpoint(&fresh_log),
            last_checkpoint(&parent_log),
            "{set} changes the run"
        );
        // ARCHITECTURE.md, "Counterfactuals": the world does not depend on who submits.
        assert_eq!(
            ticks(&fresh_log),
            ticks(&parent_log),
            "{set}: the same world"
        );
        if key == "learn.withheld" {
            assert_eq!(
                fresh.robots[k as usize].submissions, 0,
                "{set} never submits"
            );
            assert!(
                fresh.robots[k as usize].first_learn.is_none(),
                "{set} never reports"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&base);
}

/// Blaming twice gives the same report (the costs apart), and a block inside the run reads
/// the outcome there.
#[test]
fn blame_is_deterministic() {
    let base = dir("twice");
    let log = run(&base, &[]);
    let request = BlameRequest {
        at: At::Until("round >= 1".to_string()),
        robots: Some(vec![0, 1, 14]),
        ..BlameRequest::default()
    };
    let a = blame(&log, &request, &Quiet).expect("blames");
    let b = blame(&log, &request, &Quiet).expect("blames");
    assert_eq!(a.robots, b.robots);
    assert_eq!(a.outcome.to_bits(), b.outcome.to_bits());
    assert!(a.time_s < 250.0, "the outcome is read inside the run");
    assert_eq!(a.robots.len(), 3);
    let _ = std::fs::remove_dir_all(&base);
}

/// Bad input is refused with an error that names the fix, never a panic.
#[test]
fn bad_input_is_refused() {
    let base = dir("bad");
    let log = run(&base.join("run"), &[]);
    let err = |request: BlameRequest, log: &Path| {
        blame(log, &request, &Quiet)
            .expect_err("refused")
            .to_string()
    };
    let never = err(
        BlameRequest {
            at: At::Until("round > 1e9".to_string()),
            ..BlameRequest::default()
        },
        &log,
    );
    assert!(
        never.contains("never holds") && never.contains("--block"),
        "{never}"
    );
    let robot = err(
        BlameRequest {
            robots: Some(vec![99]),
            ..BlameRequest::default()
        },
        &log,
    );
    assert!(
        robot.contains("no robot 99") && robot.contains("0 to 14"),
        "{robot}"
    );
    let block = err(
        BlameRequest {
            at: At::Block(1_000_000),
            ..BlameRequest::default()
        },
        &log,
    );
    assert!(block.contains("no block 1000000"), "{block}");
    // A log cut in half.
    let cut = base.join("cut.swlog");
    let bytes = std::fs::read(&log).expect("reads");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("writes");
    let truncated = err(BlameRequest::default(), &cut);
    assert!(
        truncated.contains("cut short") && truncated.contains("re-run"),
        "{truncated}"
    );
    // A log whose header records a plug-in.
    let config =
        Config::resolve(Some("smoke"), None, &["run.duration_s=20".to_string()]).expect("valid");
    let mut header = crate::run::run_header(&config, 3);
    header
        .plugins
        .push(swarmfl_core::byzantine::plugin::PluginId::attack(
            "mine", "d", "s",
        ));
    let sim = swarmfl_core::sim::Sim::new(config, 3).expect("starts");
    let plug = base.join("plugin");
    crate::run::write_run(
        &header,
        sim,
        &plug,
        &Quiet,
        crate::run::Flush::WhenFull,
        |_| Ok(()),
    )
    .expect("writes");
    let plugin = err(BlameRequest::default(), &plug.join("run.swlog"));
    assert!(
        plugin.contains("plug-in") && plugin.contains("built-in"),
        "{plugin}"
    );
    let _ = std::fs::remove_dir_all(&base);
}

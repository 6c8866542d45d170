//! `swarmfl traffic` through the binary: its last row is the run's summary, its files are
//! written, and bad input is refused with the file or the fix named.

use std::path::{Path, PathBuf};

mod common;
use common::{scratch, swarmfl, text};

/// A 60 s smoke run of `aggregation` into `out`.
fn short_run(out: &Path, aggregation: &str) {
    let o = swarmfl(&[
        "run",
        "--preset",
        "smoke",
        "--seed",
        "2",
        "--set",
        "run.duration_s=60",
        "--set",
        &format!("learn.aggregation={aggregation}"),
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
}

/// The number after `"key":` in `json`, parsed by Rust (correctly rounded: serde_json's
/// default parser may be one unit in the last place off, and bits are compared here).
fn json_number(json: &str, key: &str) -> f64 {
    let after = json
        .split_once(&format!("\"{key}\":"))
        .unwrap_or_else(|| panic!("no {key}"))
        .1
        .trim_start();
    let end = after
        .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
        .unwrap_or(after.len());
    after[..end].parse().unwrap()
}

/// The CSV's last row's means equal summary.json's end values, bit for bit.
fn check_ends_at_summary(dir: &Path) {
    let log = dir.join("run.swlog");
    let o = swarmfl(&["traffic", log.to_str().unwrap(), "--csv", "--every", "20"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let csv = text(&o.stdout);
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let column = |row: &[&str], name: &str| -> f64 {
        let i = header.iter().position(|h| *h == name).unwrap();
        row[i].parse().unwrap()
    };
    let times: Vec<f64> = rows.iter().map(|r| column(r, "time_s")).collect();
    assert_eq!(times, [0.0, 20.0, 40.0, 60.0], "{csv}");
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let last = rows.last().unwrap();
    for (column_name, key) in [
        ("sent_mean", "bytes_sent_per_robot_mean"),
        ("stored_mean", "bytes_stored_per_robot_mean"),
    ] {
        assert_eq!(
            column(last, column_name).to_bits(),
            json_number(&summary, key).to_bits(),
            "{column_name} of {csv}"
        );
    }
}

#[test]
fn the_last_row_is_the_summary_and_a_study_gets_its_csv_and_figures() {
    let dir = scratch("study");
    for aggregation in ["chain", "gossip"] {
        short_run(&dir.join(aggregation), aggregation);
        check_ends_at_summary(&dir.join(aggregation));
    }
    let table = swarmfl(&["traffic", dir.join("chain/run.swlog").to_str().unwrap()]);
    assert!(table.status.success(), "{}", text(&table.stderr));
    let t = text(&table.stdout);
    assert!(
        t.contains("rounds, 15 robots, seed 2") && t.contains("60.0"),
        "{t}"
    );
    let out = dir.join("figures");
    let o = swarmfl(&[
        "traffic",
        dir.to_str().unwrap(),
        "--every",
        "30",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    // Every file written is listed, one a line.
    let listed = text(&o.stdout);
    let mut on_disk: Vec<PathBuf> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    on_disk.sort();
    for file in &on_disk {
        assert!(
            listed
                .lines()
                .any(|l| l.trim() == file.display().to_string()),
            "{} not listed in:\n{listed}",
            file.display()
        );
    }
    let csv = std::fs::read_to_string(out.join("traffic.csv")).unwrap();
    // Sorted by aggregation: the chain's rounds before gossip, 3 rows each (0, 30, 60 s).
    let modes: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(
        modes,
        ["rounds", "rounds", "rounds", "gossip", "gossip", "gossip"],
        "{csv}"
    );
    for stem in [
        "traffic-sent-15",
        "traffic-stored-15",
        "traffic-stored-rate",
    ] {
        for ext in ["svg", "png"] {
            assert!(out.join(format!("{stem}.{ext}")).is_file(), "{stem}.{ext}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_nonsense_period_or_a_damaged_log_is_refused_naming_the_fix_or_the_file() {
    for (every, needle) in [
        ("0", "give a period from 0.001 to 1000000 s"),
        ("-5", "give a period from 0.001 to 1000000 s"),
        ("nan", "give a period from 0.001 to 1000000 s"),
        ("1e12", "give a period from 0.001 to 1000000 s"),
        ("ten", "is not a number of seconds"),
        ("0.0005", "give a period from 0.001"),
        ("1.0005", "not a whole number of milliseconds"),
    ] {
        // The log does not exist: the period is refused before it is opened.
        let o = swarmfl(&["traffic", "absent.swlog", "--every", every]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "--every {every}: {err}");
        assert!(err.contains(needle), "--every {every}: {err}");
    }
    let dir = scratch("damaged");
    short_run(&dir, "central");
    let bytes = std::fs::read(dir.join("run.swlog")).unwrap();
    let cut = dir.join("cut.swlog");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let o = swarmfl(&["traffic", cut.to_str().unwrap()]);
    let err = text(&o.stderr);
    // A damaged log is exit 1 from every command, as from `replay` (issue #53).
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("cut.swlog") && err.contains("truncated") && err.contains("Re-run"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    let o = swarmfl(&["traffic", dir.join("absent").to_str().unwrap()]);
    let err = text(&o.stderr);
    assert!(err.contains("neither a log nor a directory"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

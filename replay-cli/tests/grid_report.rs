//! A sweep over a text key and a count (`--grid contract.rule=median,krum --grid
//! byzantine.count=1,3`) through the binary: `report` tables and names every key by its
//! values and lists the files it wrote; `ranking` tells the rules' runs apart.

use std::path::PathBuf;

mod common;
use common::{scratch, swarmfl, text};

#[test]
fn a_grid_over_rules_and_counts_is_reported_and_ranked_by_its_values() {
    let dir = scratch("rules");
    let results = dir.join("results");
    let o = swarmfl(&[
        "sweep",
        "--preset",
        "smoke",
        "--grid",
        "contract.rule=median,krum",
        "--grid",
        "byzantine.count=1,3",
        "--set",
        "byzantine.kind=faulty",
        "--set",
        "run.duration_s=120",
        "--runs",
        "1",
        "--jobs",
        "1",
        "--keep-logs",
        "--out",
        results.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));

    // report: a column per key with its values, and every file it wrote listed.
    let report = dir.join("report");
    let o = swarmfl(&[
        "report",
        results.to_str().unwrap(),
        "--out",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let listed = text(&o.stdout);
    let mut on_disk: Vec<PathBuf> = std::fs::read_dir(&report)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    on_disk.sort();
    assert!(on_disk.len() >= 10, "{on_disk:?}");
    for file in &on_disk {
        assert!(
            listed
                .lines()
                .any(|l| l.trim() == file.display().to_string()),
            "{} not listed in:\n{listed}",
            file.display()
        );
    }
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(
        md.contains("| point | contract.rule | byzantine.count | runs |"),
        "{md}"
    );
    assert!(
        md.contains("| contract.rule=krum+byzantine.count=3 | krum | 3 | 1 |"),
        "{md}"
    );

    // ranking: the rules' runs at one count and seed are different runs, the rule a column.
    let ranking = dir.join("ranking");
    let o = swarmfl(&[
        "ranking",
        results.to_str().unwrap(),
        "--out",
        ranking.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let points = std::fs::read_to_string(ranking.join("points.csv")).unwrap();
    let mut lines = points.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("ranking,kind,count,contract.rule,rounds_n,"),
        "{points}"
    );
    let rows: Vec<String> = lines
        .map(|l| l.split(',').take(4).collect::<Vec<_>>().join(","))
        .collect();
    assert_eq!(
        rows,
        [
            "median,faulty,1,krum",
            "median,faulty,1,median",
            "median,faulty,3,krum",
            "median,faulty,3,median"
        ],
        "{points}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

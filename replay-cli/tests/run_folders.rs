//! Where runs go (issue #53): every configuration gets its own default folder, nothing of
//! another configuration is replaced without being asked, and a fork never writes over its
//! parent. Driven through the `swarmfl` binary as a user types it, in a scratch folder.

use std::path::Path;
use std::process::Output;

mod common;
use common::{scratch, stderr, stdout, swarmfl_in as swarmfl};

/// The folders under `dir`, sorted.
fn folders(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A 60 s smoke run with seed 3 (a fraction of a second) and `extra` arguments.
fn short_run(cwd: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        "--preset",
        "smoke",
        "--seed",
        "3",
        "--set",
        "run.duration_s=60",
    ];
    args.extend_from_slice(extra);
    swarmfl(cwd, &args)
}

#[test]
fn runs_with_different_overrides_land_in_different_folders() {
    let dir = scratch("overrides");
    let chain = short_run(&dir, &["--quiet"]);
    assert!(chain.status.success(), "{}", stderr(&chain));
    let gossip = short_run(&dir, &["--set", "learn.aggregation=gossip"]);
    assert!(gossip.status.success(), "{}", stderr(&gossip));
    let runs = dir.join("runs");
    let names = folders(&runs);
    assert_eq!(names.len(), 2, "{names:?}");
    for name in &names {
        assert!(name.starts_with("smoke-seed3-"), "{name}");
        assert!(runs.join(name).join("summary.json").exists(), "{name}");
    }
    // The baseline's summary speaks of what it has: no chain, no contract rounds, no tokens,
    // and `inspect` at a time (it has no blocks).
    let text = stdout(&gossip);
    assert!(text.contains("aggregation: gossip"), "{text}");
    for chain_only in ["canonical height", "contract:", "tokens:", "--block"] {
        assert!(!text.contains(chain_only), "{chain_only} in\n{text}");
    }
    assert!(text.contains(" --time 30 "), "{text}");
    // The same configuration again: its own folder, replaced and said so.
    let again = short_run(&dir, &["--quiet"]);
    assert!(again.status.success(), "{}", stderr(&again));
    assert!(
        stderr(&again).contains("the same configuration and seed"),
        "{}",
        stderr(&again)
    );
    assert_eq!(folders(&runs), names);
    // A run of another configuration in a default folder (put there with --out): refused,
    // and left as it was.
    let planted = short_run(&dir, &["--quiet", "--out", "runs/smoke-seed3"]);
    assert!(planted.status.success(), "{}", stderr(&planted));
    let log = runs.join("smoke-seed3").join("run.swlog");
    let before = std::fs::read(&log).unwrap();
    let refused = swarmfl(
        &dir,
        &["run", "--preset", "smoke", "--seed", "3", "--quiet"],
    );
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    let err = stderr(&refused);
    assert!(
        err.contains("runs/smoke-seed3 holds a run of another configuration"),
        "{err}"
    );
    assert!(err.contains("run.duration_s: 60.0 -> 600.0"), "{err}");
    assert!(err.contains("--force"), "{err}");
    assert_eq!(std::fs::read(&log).unwrap(), before);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_fork_never_writes_over_its_parent() {
    let dir = scratch("fork");
    let parent = short_run(&dir, &["--quiet", "--out", "parent"]);
    assert!(parent.status.success(), "{}", stderr(&parent));
    let log = dir.join("parent").join("run.swlog");
    let before = std::fs::read(&log).unwrap();
    // Into the parent's own folder, or a folder that holds it: refused before anything is
    // written, naming the default folder as the fix.
    for out in ["parent", ".", "./parent/"] {
        let fork = swarmfl(
            &dir,
            &[
                "fork",
                "parent/run.swlog",
                "--at",
                "2",
                "--set",
                "contract.security=false",
                "--out",
                out,
            ],
        );
        let err = stderr(&fork);
        assert_eq!(fork.status.code(), Some(2), "{out}: {err}");
        assert!(err.contains("would write over its parent"), "{err}");
        assert!(err.contains("the default is parent-fork-at-2-"), "{err}");
        assert_eq!(std::fs::read(&log).unwrap(), before, "{out}");
        assert_eq!(folders(&dir.join("parent")), ["run.swlog", "summary.json"]);
    }
    // The default: beside the parent, named for the height and the overrides.
    let fork = swarmfl(
        &dir,
        &[
            "fork",
            "parent/run.swlog",
            "--at",
            "2",
            "--set",
            "contract.security=false",
            "--quiet",
        ],
    );
    assert!(fork.status.success(), "{}", stderr(&fork));
    let names = folders(&dir);
    assert_eq!(names.len(), 2, "{names:?}");
    assert!(names[1].starts_with("parent-fork-at-2-"), "{names:?}");
    assert_eq!(std::fs::read(&log).unwrap(), before);
    let _ = std::fs::remove_dir_all(&dir);
}

//! The rough edges a new user hit (issue #35, "Messages and numbers"): each defect, driven
//! through the `swarmfl` binary as a user types it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn swarmfl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_swarmfl"))
        .args(args)
        .output()
        .expect("running swarmfl")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A fresh folder of this test process under the system's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("swarmfl-rough-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `swarmfl run --preset smoke --seed SEED --out OUT` with `extra` arguments after it.
fn smoke_run(out: &Path, seed: &str, extra: &[&str]) -> Output {
    let out = out.to_str().unwrap();
    let mut args = vec!["run", "--preset", "smoke", "--seed", seed, "--out", out];
    args.extend_from_slice(extra);
    swarmfl(&args)
}

/// A 60 s smoke run into `out` (a few hundred records: quick in a test).
fn short_run(out: &Path, seed: &str) -> Output {
    smoke_run(out, seed, &["--set", "run.duration_s=60"])
}

#[test]
fn a_set_error_is_said_once_in_the_configurations_own_words() {
    let out = swarmfl(&["run", "--preset", "smoke", "--set", "byzantine.kind=faulty"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.matches("is out of range").count(), 1, "{err}");
    assert!(err.contains("byzantine.kind is \"faulty\""), "{err}");
    assert!(!err.contains("Faulty"), "{err}");
    let out = swarmfl(&[
        "run",
        "--preset",
        "smoke",
        "--set",
        "faults.crashes=[{robot=30,start_s=50,end_s=120}]",
    ]);
    let err = stderr(&out);
    assert!(
        err.contains(
            "`faults.crashes[0].robot`: value 30 is out of range; allowed: a robot id from 0 to 14"
        ),
        "{err}"
    );
    assert!(!err.contains("you did not set"), "{err}");
    assert_eq!(err.matches("is out of range").count(), 1, "{err}");
}

#[test]
fn a_typo_in_a_rule_suggests_the_nearest_choice() {
    let out = swarmfl(&["run", "--preset", "smoke", "--set", "contract.rule=krumm"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("unknown value `krumm`; did you mean `krum`?"),
        "{err}"
    );
    assert!(err.contains("`multi-krum`"), "{err}");
}

#[test]
fn run_replaces_a_previous_run_whole_and_refuses_a_folder_of_other_files() {
    let dir = scratch("out");
    let run = dir.join("run");
    assert!(short_run(&run, "1").status.success());
    std::fs::write(run.join("run.html"), "the previous run's page").unwrap();
    let again = short_run(&run, "2");
    assert!(again.status.success(), "{}", stderr(&again));
    assert!(
        stderr(&again).contains("replacing the previous run in"),
        "{}",
        stderr(&again)
    );
    assert!(stderr(&again).contains("seed 1"), "{}", stderr(&again));
    assert!(
        !run.join("run.html").exists(),
        "the old page is left beside the new log"
    );
    // A folder with someone's files and no run: refused, nothing written into it.
    let theirs = dir.join("theirs");
    std::fs::create_dir_all(&theirs).unwrap();
    std::fs::write(theirs.join("notes.txt"), "mine").unwrap();
    let out = short_run(&theirs, "1");
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("holds other files (notes.txt) but no run"),
        "{}",
        stderr(&out)
    );
    assert!(!theirs.join("run.swlog").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn run_explains_its_numbers_and_its_hints_can_be_pasted() {
    let dir = scratch("numbers");
    let out = short_run(&dir.join("run"), "1");
    let text = stdout(&out);
    assert!(out.status.success(), "{}", stderr(&out));
    // The timing line is seconds, not a JSON object of 17-digit floats.
    let timing = text.lines().find(|l| l.starts_with("timing:")).unwrap();
    assert!(
        timing.contains("world ") && timing.contains(" s (") && !timing.contains('{'),
        "{timing}"
    );
    // The block count says what it counts.
    assert!(text.contains("canonical height"), "{text}");
    // The hints name a command this shell can run: the binary's own path here.
    let me = env!("CARGO_BIN_EXE_swarmfl");
    let hint = text.lines().find(|l| l.contains(" replay ")).unwrap();
    assert!(
        hint.trim_start().starts_with(me) || hint.trim_start().starts_with("swarmfl "),
        "{hint}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_clean_runs_negative_gain_is_shown_as_stake_still_locked() {
    let dir = scratch("gain");
    // 600 s of smoke: rounds close, and one is open at the end.
    let out = smoke_run(&dir.join("r"), "7", &[]);
    let text = stdout(&out);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        text.contains("the stakes the contract still holds for the round open at the end"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn diff_tells_an_unreadable_log_from_logs_that_differ() {
    let dir = scratch("diff");
    assert!(short_run(&dir.join("a"), "1").status.success());
    let log = dir.join("a/run.swlog");
    let bytes = std::fs::read(&log).unwrap();
    let cut = dir.join("cut.swlog");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let out = swarmfl(&["diff", log.to_str().unwrap(), cut.to_str().unwrap()]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}{}",
        stdout(&out),
        stderr(&out)
    );
    assert!(
        stderr(&out).contains("exit 1 means the logs were read and differ"),
        "{}",
        stderr(&out)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn durations_have_one_name_one_range_and_negative_values_are_values() {
    let chaos = swarmfl(&["chaos", "--seeds", "1", "--duration", "-5"]);
    let bench = swarmfl(&["bench", "scale", "--robots", "15", "--duration", "1e12"]);
    for (out, value) in [(&chaos, "-5"), (&bench, "1000000000000")] {
        let err = stderr(out);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(!err.contains("unexpected argument"), "{err}");
        assert!(
            err.contains(&format!(
                "{value} seconds is out of range; allowed: a number in (0, 10000000]"
            )),
            "{err}"
        );
    }
    // The old spelling still works for scripts.
    let old = swarmfl(&["bench", "scale", "--robots", "15", "--duration-s", "-1"]);
    assert!(stderr(&old).contains("out of range"), "{}", stderr(&old));
}

#[test]
fn inspect_names_the_last_robot_and_prints_distances_in_model_units() {
    let dir = scratch("inspect");
    let out = smoke_run(&dir.join("r"), "7", &["--quiet"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let log = dir.join("r/run.swlog");
    let out = swarmfl(&[
        "inspect",
        log.to_str().unwrap(),
        "--block",
        "40",
        "--robot",
        "99",
    ]);
    assert!(
        stderr(&out).contains("the swarm has robots 0 to 14"),
        "{}",
        stderr(&out)
    );
    let out = swarmfl(&["inspect", log.to_str().unwrap(), "--block", "40"]);
    let text = stdout(&out);
    assert!(out.status.success(), "{}", stderr(&out));
    // Every distance shown is the per-weight number `run` prints, never raw fixed-point units.
    let distances: Vec<&str> = text.lines().filter(|l| l.contains("distance")).collect();
    assert!(!distances.is_empty(), "{text}");
    assert!(distances.iter().all(|l| l.contains("per weight")), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

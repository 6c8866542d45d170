//! The rough edges a new user hit (issue #35, "Messages and numbers"): each defect, driven
//! through the `swarmfl` binary as a user types it.

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::{scratch, stderr, stdout, swarmfl};

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

#[test]
fn snapshot_titles_the_run_and_refuses_a_time_past_its_end() {
    let dir = scratch("snapshot");
    let out = short_run(&dir.join("r"), "7");
    assert!(out.status.success(), "{}", stderr(&out));
    let log = dir.join("r/run.swlog");
    let log = log.to_str().unwrap();
    let png = dir.join("s.png");
    let png = png.to_str().unwrap();
    let out = swarmfl(&["snapshot", log, "--time", "9999", "--out", png]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--time 9999 is past the end of")
            && err.contains("its last tick is at t = 60.000 s")
            && err.contains("give a time from 0 to 60, or --block HEIGHT"),
        "{err}"
    );
    assert!(
        !Path::new(png).exists(),
        "a refused snapshot wrote a picture"
    );
    // The run's own end is a time of the run; the title names the run, not the file.
    let out = swarmfl(&["snapshot", log, "--time", "60", "--out", png]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("(preset smoke, seed 7: t = 60.000 s; from "),
        "{}",
        stdout(&out)
    );
    let svg = dir.join("s.svg");
    let out = swarmfl(&[
        "snapshot",
        log,
        "--block",
        "2",
        "--out",
        svg.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&svg).unwrap().replace('\n', "");
    assert!(text.contains("preset smoke, seed 7: t = "), "no run title");
    assert!(
        text.contains("right after block 2"),
        "no block in the title"
    );
    assert!(!text.contains("run.swlog"), "the title is the file path");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The number just before `words` in `text` (e.g. "81" in "81 sealings on all forks").
fn number_before(text: &str, words: &str) -> u64 {
    let at = text
        .find(words)
        .unwrap_or_else(|| panic!("no `{words}` in: {text}"));
    let digits: String = text[..at]
        .trim_end()
        .chars()
        .rev()
        .take_while(char::is_ascii_digit)
        .collect();
    digits
        .chars()
        .rev()
        .collect::<String>()
        .parse()
        .unwrap_or_else(|_| panic!("no number before `{words}` in: {text}"))
}

/// The number just after `words` in `text` (e.g. "59" in "canonical height 59").
fn number_after(text: &str, words: &str) -> u64 {
    let at = text
        .find(words)
        .unwrap_or_else(|| panic!("no `{words}` in: {text}"))
        + words.len();
    let digits: String = text[at..]
        .trim_start()
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    digits
        .parse()
        .unwrap_or_else(|_| panic!("no number after `{words}` in: {text}"))
}

#[test]
fn block_counts_say_what_they_count_and_agree_between_commands() {
    let dir = scratch("blocks");
    // 600 s of smoke: forks and reorgs happen, so "all forks" and "final chain" differ.
    let out = smoke_run(&dir.join("r"), "7", &[]);
    let run = stdout(&out);
    assert!(out.status.success(), "{}", stderr(&out));
    let log = dir.join("r/run.swlog");
    let log = log.to_str().unwrap();
    let replay = stdout(&swarmfl(&["replay", log]));
    let html = dir.join("v.html");
    let view = stdout(&swarmfl(&["view", log, "--out", html.to_str().unwrap()]));
    let csv = dir.join("csv");
    let export = stdout(&swarmfl(&["export", log, "--out", csv.to_str().unwrap()]));
    let height = number_after(&run, "canonical height");
    let sealings = number_before(&run, "sealings on all forks (every block any node sealed");
    assert!(sealings > height, "forks in a 600 s smoke run: {run}");
    assert!(
        run.contains("blocks of the final chain, genesis apart"),
        "{run}"
    );
    for (command, text) in [("replay", &replay), ("view", &view)] {
        assert_eq!(
            number_before(
                text,
                "sealings on all forks (every block any node sealed, genesis apart"
            ),
            sealings,
            "{command}: {text}"
        );
    }
    assert_eq!(
        number_after(&replay, "the final canonical chain has height"),
        height,
        "{replay}"
    );
    assert_eq!(
        number_after(&view, "final canonical chain height"),
        height,
        "{view}"
    );
    assert_eq!(
        number_before(&export, "blocks of the final canonical chain"),
        height,
        "{export}"
    );
    assert_eq!(
        number_before(&export, "sealings on all forks"),
        sealings,
        "{export}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bench_world_says_what_it_is_doing_before_its_long_first_case() {
    use std::io::BufRead;
    // The command takes 16-19 s; its first line must come before the first case's work, so
    // the test reads one line of stderr and stops the command (with the old silent command
    // the line would never come and stderr would close empty at its end).
    let mut child = Command::new(env!("CARGO_BIN_EXE_swarmfl"))
        .args(["bench", "world", "--json"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stderr.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let _ = child.kill();
    let _ = child.wait();
    assert!(
        line.starts_with("bench world: paper-15, 15 robots") && line.contains("run 1 of 3"),
        "{line}"
    );
}

/// The data object of a `swarmfl view` page.
fn page_data(html: &Path) -> serde_json::Value {
    let page = std::fs::read_to_string(html).unwrap();
    let start = page
        .find(r#"<script id="data" type="application/json">"#)
        .expect("the page has its data")
        + r#"<script id="data" type="application/json">"#.len();
    let end = start + page[start..].find("</script>").unwrap();
    serde_json::from_str(&page[start..end].replace("<\\/", "</")).unwrap()
}

#[test]
fn view_shows_a_baselines_aggregations_as_summary_and_export_count_them() {
    // Issue #34: the viewer of a gossip or central run showed an empty chain.
    for kind in ["gossip", "central"] {
        let dir = scratch(&format!("view-{kind}"));
        let set = format!("learn.aggregation={kind}");
        let out = smoke_run(
            &dir.join("r"),
            "7",
            &["--set", &set, "--set", "run.duration_s=300", "--quiet"],
        );
        assert!(out.status.success(), "{}", stderr(&out));
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("r/summary.json")).unwrap())
                .unwrap();
        let count = summary["contract"]["rounds"].as_u64().unwrap();
        assert!(count > 0, "{kind}: a 300 s smoke run aggregates");
        let log = dir.join("r/run.swlog");
        let html = dir.join("v.html");
        let view = swarmfl(&[
            "view",
            log.to_str().unwrap(),
            "--out",
            html.to_str().unwrap(),
        ]);
        let said = stdout(&view);
        assert!(view.status.success(), "{}", stderr(&view));
        assert!(
            said.contains(&format!(
                "a {kind} run has no blocks: its {count} aggregations"
            )),
            "{said}"
        );
        let data = page_data(&html);
        assert_eq!(data["aggregation"], kind);
        let rounds = data["rounds"].as_array().unwrap();
        assert_eq!(
            rounds.len() as u64,
            count,
            "{kind}: the page's aggregations"
        );
        // The same losses, in the same order, as summary.json's.
        let losses: Vec<f64> = rounds.iter().map(|r| r[3].as_f64().unwrap()).collect();
        let want: Vec<f64> = summary["contract"]["loss_by_round"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(losses, want, "{kind}");
        // Per-robot versions in every frame, never going back, some robot past genesis at the end.
        let versions = data["versions"].as_array().unwrap();
        assert_eq!(versions.len(), data["t"].as_array().unwrap().len());
        let robots = data["robots"].as_u64().unwrap() as usize;
        let at = |f: usize, r: usize| versions[f][r].as_u64().unwrap();
        for f in 1..versions.len() {
            for r in 0..robots {
                assert!(at(f, r) >= at(f - 1, r), "{kind}: frame {f}, robot {r}");
            }
        }
        assert!((0..robots).any(|r| at(versions.len() - 1, r) > 0), "{kind}");
        // export's rounds table has the same rows.
        let csv = dir.join("csv");
        let export = swarmfl(&[
            "export",
            log.to_str().unwrap(),
            "--out",
            csv.to_str().unwrap(),
        ]);
        assert!(export.status.success(), "{}", stderr(&export));
        let rows = std::fs::read_to_string(csv.join("rounds.csv")).unwrap();
        assert_eq!(rows.lines().count() as u64, count + 1, "{kind}: {rows}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// A log of just a header with `config_toml` (and a footer): what a foreign or older build, or a
/// hand-edited header, leaves for this one to read.
fn header_only_log(path: &Path, config_toml: String) {
    use swarmfl_core::log::{Header, LogWriter};
    let writer = LogWriter::create(path, &Header::new(7, config_toml)).unwrap();
    writer.finish().unwrap();
}

/// How often `needle` stands in `text`.
fn count(text: &str, needle: &str) -> usize {
    text.matches(needle).count()
}

#[test]
fn a_header_this_build_refuses_is_said_with_its_cause_once() {
    let dir = scratch("header");
    // Valid key by key (each within its range), but the robots cannot be placed: the run
    // cannot start from this header.
    let out = swarmfl(&[
        "config",
        "--preset",
        "smoke",
        "--set",
        "world.robot_radius_m=5",
        "--set",
        "world.arena_side_m=4",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let unplaceable = dir.join("unplaceable.swlog");
    header_only_log(&unplaceable, stdout(&out));
    let cause = "it is larger than the arena";
    let log = unplaceable.to_str().unwrap();
    let (html, csv) = (dir.join("v.html"), dir.join("csv"));
    let commands: [Vec<&str>; 4] = [
        vec!["replay", log],
        vec!["replay", "--resimulate", log],
        vec!["view", log, "--out", html.to_str().unwrap()],
        vec!["export", log, "--out", csv.to_str().unwrap()],
    ];
    for args in &commands {
        let out = swarmfl(args);
        let text = stderr(&out);
        assert!(!out.status.success(), "{args:?} accepted the log: {text}");
        assert_eq!(
            count(&text, cause),
            1,
            "{args:?}: the cause not said once: {text}"
        );
        assert_eq!(
            count(&text, "cannot start the run of the header"),
            1,
            "{args:?}: {text}"
        );
    }
    // A header whose configuration this build refuses outright (a value out of range).
    let out = swarmfl(&["config", "--preset", "smoke"]);
    let toml = stdout(&out).replace("robot_radius_m = ", "robot_radius_m = 100 #");
    assert!(toml.contains("robot_radius_m = 100"), "{toml}");
    let refused = dir.join("refused.swlog");
    header_only_log(&refused, toml);
    let out = swarmfl(&["replay", refused.to_str().unwrap()]);
    let text = stderr(&out);
    assert!(!out.status.success(), "{text}");
    assert_eq!(
        count(&text, "out of range"),
        1,
        "the cause not said once: {text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_predicate_that_cannot_be_evaluated_is_said_with_its_cause_once() {
    let dir = scratch("eval");
    assert!(short_run(&dir.join("r"), "1").status.success());
    let log = dir.join("r/run.swlog");
    let out = swarmfl(&[
        "bisect",
        log.to_str().unwrap(),
        "--until",
        "balance[99] > 1",
    ]);
    let text = stderr(&out);
    assert!(!out.status.success(), "{text}");
    assert_eq!(count(&text, "there is no robot 99"), 1, "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue #53: a run's folder where its log is expected says which file to give, in every
/// command that reads a log (not the system's "Is a directory").
#[test]
fn a_runs_folder_given_for_its_log_names_the_log() {
    let dir = scratch("folder-for-log");
    let run = dir.join("run");
    let out = short_run(&run, "7");
    assert!(out.status.success(), "{}", stderr(&out));
    let r = run.to_str().unwrap();
    let html = dir.join("v.html");
    let svg = dir.join("s.svg");
    let csv = dir.join("csv");
    let want = format!("{r}: is a directory: give {r}/run.swlog (the log the run wrote there)");
    for args in [
        vec!["replay", r],
        vec!["replay", r, "--resimulate"],
        vec!["view", r, "--out", html.to_str().unwrap()],
        vec![
            "snapshot",
            r,
            "--time",
            "10",
            "--out",
            svg.to_str().unwrap(),
        ],
        vec!["inspect", "--block", "1", r],
        vec!["export", r, "--out", csv.to_str().unwrap()],
        vec!["diff", r, r],
    ] {
        let out = swarmfl(&args);
        let err = stderr(&out);
        assert!(!out.status.success(), "{args:?}");
        assert!(err.contains(&want), "{args:?}: {err}");
        assert!(!err.contains("os error"), "{args:?}: {err}");
    }
    // A folder without a log says what a log is.
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let err = stderr(&swarmfl(&["replay", empty.to_str().unwrap()]));
    assert!(
        err.contains("is a directory and holds no run.swlog: give a log file"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

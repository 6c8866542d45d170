//! Issue #53: the command reads a plug-in attack's log from its records (a fold, the viewer, a
//! snapshot, the tables) without the attack, which only a re-simulation runs; a plug-in rule's
//! log, whose contract every fold re-executes, still gives its world (a snapshot at a time, the
//! viewer's frames with a note in place of the contract's panes).
//! The logs are made in this process with plug-ins written in Rust (as the Python package
//! offers its own); the command, another process, has none.

use std::sync::Arc;

use swarmfl_core::byzantine::plugin::{PluginId, Plugins};
use swarmfl_core::byzantine::{Action, Attack, View};
use swarmfl_core::config::Config;
use swarmfl_core::contract::rules::plugin::RulePlugin;
use swarmfl_core::contract::rules::Input;
use swarmfl_core::rng::Rng;
use swarmfl_study::progress::Quiet;
use swarmfl_study::run::RunRequest;

mod common;
use common::{scratch, swarmfl};

/// Submits the shared model back, claiming the configured sample count.
struct Echo;

impl Attack for Echo {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        Action::Submit {
            weights: view.shared(),
            samples: view.config.claimed_samples,
        }
    }
}

/// The mean of the accepted models, truncated toward zero.
struct Mean;

impl RulePlugin for Mean {
    fn aggregate(&self, current: &[i64], inputs: &[Input], _f: usize) -> Result<Vec<i64>, String> {
        let n = inputs.len() as i64;
        Ok((0..current.len())
            .map(|i| inputs.iter().map(|m| m.weights[i]).sum::<i64>() / n)
            .collect())
    }
}

#[test]
fn a_plugin_attacks_log_is_read_from_its_records_and_only_resimulation_needs_the_attack() {
    let dir = scratch("attack");
    let run = dir.join("run");
    let overrides: Vec<String> = [
        "run.duration_s=60",
        "byzantine.kind=plugin",
        "byzantine.plugin=echo",
        "byzantine.count=2",
    ]
    .map(String::from)
    .to_vec();
    let config = Config::resolve(Some("smoke"), None, &overrides).unwrap();
    let mut plugins = Plugins::none();
    plugins.add_attack(PluginId::attack("echo", "00", "a test"), Arc::new(Echo));
    let outcome = RunRequest::new(config, 7, &run)
        .plugins(&plugins)
        .run(&Quiet)
        .unwrap();
    let log = run.join("run.swlog");
    let log = log.to_str().unwrap();
    let html = dir.join("v.html");
    let svg = dir.join("s.svg");
    let csv = dir.join("csv");
    for args in [
        vec!["replay", log],
        vec!["view", log, "--out", html.to_str().unwrap()],
        vec![
            "snapshot",
            log,
            "--time",
            "30",
            "--out",
            svg.to_str().unwrap(),
        ],
        vec!["inspect", "--block", "1", log],
        vec!["export", log, "--out", csv.to_str().unwrap()],
    ] {
        let out = swarmfl(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {err}");
    }
    let out = swarmfl(&["replay", log]);
    let hash = outcome.summary.run.final_hash.as_str();
    assert!(
        String::from_utf8_lossy(&out.stdout).contains(hash),
        "the fold ends at the run's final hash"
    );
    // A re-simulation runs the attack: the command says it cannot.
    let out = swarmfl(&["replay", log, "--resimulate"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("plug-in attack `echo`") && err.contains("cannot run plug-ins"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_plugin_rules_log_gives_its_world_to_the_command_and_says_where_the_rest_is_drawn() {
    let dir = scratch("rule");
    let run = dir.join("run");
    let overrides: Vec<String> = [
        "run.duration_s=60",
        "contract.rule=plugin",
        "contract.rule_plugin=mean",
    ]
    .map(String::from)
    .to_vec();
    let config = Config::resolve(Some("smoke"), None, &overrides).unwrap();
    let mut plugins = Plugins::none();
    plugins.add_rule(PluginId::rule("mean", "11", "a test"), Arc::new(Mean));
    RunRequest::new(config, 7, &run)
        .plugins(&plugins)
        .run(&Quiet)
        .unwrap();
    let log = run.join("run.swlog");
    let log = log.to_str().unwrap();
    // The world is records: the command draws it at a time, as this process (which has the
    // rule) does.
    let svg = dir.join("s.svg");
    let out = swarmfl(&[
        "snapshot",
        log,
        "--time",
        "30",
        "--out",
        svg.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let here = dir.join("here.svg");
    swarmfl_study::snapshot::snapshot(
        run.join("run.swlog").as_path(),
        Some(30.0),
        None,
        &here,
        &Quiet,
    )
    .unwrap();
    assert_eq!(std::fs::read(&svg).unwrap(), std::fs::read(&here).unwrap());
    // A block of the final chain needs the rule's aggregates: the command names where to draw it.
    let out = swarmfl(&[
        "snapshot",
        log,
        "--block",
        "1",
        "--out",
        svg.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("plug-in rule `mean`")
            && err.contains("swarmfl.open(..., rule=...).view(OUT) and .snapshot(OUT, ...)"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The data object of a viewer page.
fn page_data(html: &str) -> serde_json::Value {
    let start = "<script id=\"data\" type=\"application/json\">";
    let from = html.find(start).expect("the page has its data") + start.len();
    let to = from + html[from..].find("</script>").expect("the data ends");
    serde_json::from_str(&html[from..to]).expect("the data is JSON")
}

#[test]
fn the_viewer_draws_a_plugin_rules_log_from_its_records_and_notes_what_needs_the_rule() {
    let dir = scratch("view-rule");
    let run = dir.join("run");
    let overrides: Vec<String> = [
        "run.duration_s=60",
        "contract.rule=plugin",
        "contract.rule_plugin=mean",
    ]
    .map(String::from)
    .to_vec();
    let config = Config::resolve(Some("smoke"), None, &overrides).unwrap();
    let mut plugins = Plugins::none();
    plugins.add_rule(PluginId::rule("mean", "11", "a test"), Arc::new(Mean));
    RunRequest::new(config, 7, &run)
        .plugins(&plugins)
        .run(&Quiet)
        .unwrap();
    let log = run.join("run.swlog");
    let html = dir.join("v.html");
    let out = swarmfl(&[
        "view",
        log.to_str().unwrap(),
        "--out",
        html.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let note = "the plug-in `mean`, not loaded: contract results";
    let python = "swarmfl.open(LOG, rule=...).view(OUT)";
    assert!(stdout.contains(note) && stdout.contains(python), "{stdout}");
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(
        page.contains("id=\"ruleNote\"") && page.contains(note) && page.contains(python),
        "the page shows the note"
    );
    let data = page_data(&page);
    assert_eq!(data["plugin_rule"]["name"], "mean");
    // Frames of the world (every tick of a 60 s run, and time 0): the robots' poses, which
    // move, and the radio links.
    let (t, pose) = (
        data["t"].as_array().unwrap(),
        data["pose"].as_array().unwrap(),
    );
    assert!(t.len() > 100, "{} frames", t.len());
    assert_eq!(pose.len(), t.len());
    assert_eq!(data["links"].as_array().unwrap().len(), t.len());
    assert_ne!(pose[0], pose[t.len() - 1], "the robots move");
    let robots = data["robots"].as_u64().unwrap() as usize;
    assert_eq!(pose[0].as_array().unwrap().len(), 3 * robots);
    assert_eq!(data["byzantine"].as_array().unwrap().len(), robots);
    // The last frame is the world at the run's end, as the snapshot at that time draws it.
    let end_s = t[t.len() - 1].as_u64().unwrap() as f64 / 1000.0;
    let (world, _, _) =
        swarmfl_core::replay::world_at_time(&log, swarmfl_core::SimTime::from_secs(end_s)).unwrap();
    let x0 = (world.poses()[0].x * 1000.0).round() as i64;
    assert_eq!(pose[t.len() - 1][0].as_i64(), Some(x0));
    std::fs::remove_dir_all(&dir).unwrap();
}

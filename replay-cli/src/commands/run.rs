//! `swarmfl run`: simulate a run into `DIR/run.swlog` and `DIR/summary.json` (the run itself
//! is [`swarmfl_study::run`]), then print its summary and what to try next.

use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use swarmfl_core::config::Aggregation;
use swarmfl_study::run::{density_warning, run, run_header, run_with, Flush, RunOutcome};
use swarmfl_study::run_dir;

use crate::cli::RunArgs;
use crate::progress::Bar;

/// Runs `swarmfl run`: the run into `--out` (default [`run_dir::default_run_dir`]: distinct
/// per configuration), then its summary and what to try next unless `--quiet`. A run already in
/// the folder is replaced or refused as [`run_dir::prepare`] says.
pub fn command(args: RunArgs) -> anyhow::Result<ExitCode> {
    let RunArgs {
        config: config_args,
        seed,
        out,
        force,
        quiet,
        live,
        port,
    } = args;
    let config = config_args.resolve()?;
    let (out, chosen) = run_dir::choose(out, force, || {
        // The file was read once by `resolve`; a second read that fails says so.
        let file = match &config_args.config {
            Some(path) => Some(
                std::fs::read(path)
                    .with_context(|| format!("cannot read --config {}", path.display()))?,
            ),
            None => None,
        };
        Ok(run_dir::default_run_dir(
            &config.preset,
            seed,
            &config_args.overrides,
            file.as_deref(),
        ))
    })?;
    if let Some(warning) = density_warning(&config) {
        eprintln!("{warning}");
    }
    // Bound before the previous run is cleared: a port in use changes nothing on disk.
    let server = match live {
        true => Some(crate::commands::live::Live::bind(port)?),
        false => None,
    };
    if let Some(replaced) = run_dir::prepare(&out, &run_header(&config, seed), chosen)? {
        eprintln!("{replaced}");
    }
    let outcome = match server {
        None => run(config, seed, &out, &Bar::new(quiet))?,
        Some(server) => {
            let live = server.start(&out.join("run.swlog"));
            eprintln!(
                "live view: {} (while the run goes; Ctrl-C stops the run and the view)",
                live.url()
            );
            let never = std::sync::atomic::AtomicBool::new(false);
            let outcome = run_with(config, seed, &out, &Bar::new(quiet), &never, LIVE_FLUSH);
            // Whether the run ended or failed, the page gets the log as it is and says so.
            live.finish();
            outcome?
        }
    };
    if !quiet {
        print_summary(&outcome);
        print_next(&outcome);
    }
    Ok(ExitCode::SUCCESS)
}

/// How far behind the run the live view's reader of the log may fall: the log is flushed at
/// the first record after this much wall time.
const LIVE_FLUSH: Flush = Flush::Every(Duration::from_millis(250));

/// Prints the short human summary of a run ([`summary_text`]).
pub fn print_summary(outcome: &RunOutcome) {
    print!(
        "{}",
        summary_text(&outcome.summary, &outcome.log_path, outcome.sealings)
    );
}

/// How the run's models were aggregated, from its summary (`chain` when it does not say: the
/// summaries written before the baselines).
fn aggregation_kind(summary: &serde_json::Value) -> Aggregation {
    serde_json::from_value(summary["aggregation"]["kind"].clone()).unwrap_or_default()
}

/// A loss as `run` prints it: four decimals, `-` when there is none.
fn loss(v: &serde_json::Value) -> String {
    v.as_f64().map_or("-".to_string(), |x| format!("{x:.4}"))
}

/// Megabytes with three decimals, `-` when there are none.
fn mb(v: &serde_json::Value) -> String {
    v.as_f64()
        .map_or("-".to_string(), |x| format!("{:.3}", x / 1e6))
}

/// The losses at aggregations 1, 10, 25, 50 and the last, as ` {p}1=... {p}10=...`.
fn loss_points(contract: &serde_json::Value, prefix: &str) -> String {
    let rounds = contract["rounds"].as_u64().unwrap_or(0);
    let losses = contract["loss_by_round"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let mut shown = String::new();
    for r in [1u64, 10, 25, 50, rounds] {
        let label = format!("{prefix}{r}=");
        if r >= 1 && r <= rounds && !shown.contains(&format!(" {label}")) {
            let value = losses
                .get((r - 1) as usize)
                .unwrap_or(&serde_json::Value::Null);
            shown.push_str(&format!(" {label}{}", loss(value)));
        }
    }
    match shown.is_empty() {
        true => " -".to_string(),
        false => shown,
    }
}

/// The short human summary of a run (`summary` as in `summary.json`, its log at `log`,
/// `sealings` blocks sealed on all forks): what every run has, then the contract, tokens and
/// ledger of a chain run or the aggregations and traffic of a baseline (which has no chain,
/// contract or tokens), then timing and the final hash.
pub fn summary_text(summary: &serde_json::Value, log: &Path, sealings: u64) -> String {
    let s = summary;
    let kind = aggregation_kind(s);
    let mut out = vec![
        format!("log:        {}", log.display()),
        format!(
            "run:        preset {} seed {}, {} robots, {} simulated s",
            s["preset"].as_str().unwrap_or("?"),
            s["seed"],
            s["robots"],
            s["sim_time_s"]
        ),
        format!("records:    {} ({} bytes)", s["records"], s["log_bytes"]),
    ];
    if let Some(world) = s.get("world") {
        out.push(format!(
            "world:      collisions {}, mean neighbours {:.2}, samples/robot/600 s {:.1}",
            world["collisions"],
            world["mean_neighbours"].as_f64().unwrap_or(0.0),
            world["samples_per_robot_per_600s"].as_f64().unwrap_or(0.0)
        ));
    }
    match kind {
        Aggregation::Chain => chain_lines(s, sealings, &mut out),
        Aggregation::Gossip => gossip_lines(s, &mut out),
        Aggregation::Central => central_lines(s, &mut out),
    }
    if let Some(gas) = s.get("evm_gas") {
        let mean = |kind: &str| {
            gas[kind]["mean_gas"]
                .as_u64()
                .map_or("-".into(), |g| g.to_string())
        };
        out.push(format!(
            "evm gas:    submission {} (mean), aggregating submission {}, outlier {}, deploy {}; \
             contract wall time is inside ledger_s below",
            mean("accepted"),
            mean("aggregated"),
            mean("outlier"),
            mean("deploy")
        ));
    }
    out.push(format!("timing:     {}", timing_line(&s["timing"], kind)));
    out.push(format!(
        "final hash: {}",
        s["final_hash"].as_str().unwrap_or("?")
    ));
    out.push(format!(
        "wall time:  {:.2} s",
        s["wall_s"].as_f64().unwrap_or(0.0)
    ));
    out.join("\n") + "\n"
}

/// A chain run's contract, tokens, aggregation traffic and ledger.
fn chain_lines(s: &serde_json::Value, sealings: u64, out: &mut Vec<String>) {
    let c = &s["contract"];
    out.push(format!(
        "contract:   {} rounds; loss by round:{}",
        c["rounds"].as_u64().unwrap_or(0),
        loss_points(c, "r")
    ));
    out.push(format!(
        "            held-out loss {} -> {}; submissions {}",
        loss(&c["heldout_loss_initial"]),
        loss(&c["final_heldout_loss"]),
        c["submissions"]
    ));
    out.push(format!(
        "            mean honest distance {} (outlier threshold {})",
        loss(&c["mean_honest_distance"]),
        c["outlier_threshold"]
    ));
    let t = &s["tokens"];
    out.push(format!(
        "tokens:     honest mean gain {}, Byzantine mean gain {}, total units {} -> {}",
        loss(&t["honest_mean_gain"]),
        loss(&t["byzantine_mean_gain"]),
        t["total_units_start"],
        t["total_units_end"]
    ));
    if let Some(held) = t["contract_holdings"].as_f64().filter(|h| *h > 0.0) {
        // Without this a clean run's negative gain reads as a loss: it is stake still locked.
        out.push(format!(
            "            (gains count {held:.3} tokens as spent: the stakes the contract still \
             holds for the round open at the end)"
        ));
    }
    let a = &s["aggregation"];
    if a.is_object() {
        out.push(format!(
            "aggregation: {}; sent {} MB/robot, stored {} MB/robot; conservation {}",
            a["kind"].as_str().unwrap_or("?"),
            mb(&a["bytes_sent_per_robot_mean"]),
            mb(&a["bytes_stored_per_robot_mean"]),
            a["conservation"].as_str().unwrap_or("?")
        ));
    }
    let l = &s["ledger"];
    out.push(format!(
        "ledger:     canonical height {} (blocks of the final chain, genesis apart), {} \
         sealings on all forks (every block any node sealed, as `replay`, `view` and `export` \
         count them), forks {}, reorgs {} (deepest {}), tx delay median {} s p95 {} s, {:.0} \
         B/submission",
        l["canonical_height"],
        sealings,
        l["forks"],
        l["reorgs"],
        l["deepest_reorg"],
        l["tx_delay_median_s"],
        l["tx_delay_p95_s"],
        l["bytes_per_submission"].as_f64().unwrap_or(0.0)
    ));
}

/// What a baseline's summary says about the models it averaged: `N honest and M Byzantine
/// models averaged`, and the models written (`accepted`, with the duplicates dropped if any).
/// The summary's `contract` section holds a baseline's figures under the chain's names.
fn baseline_models(c: &serde_json::Value) -> (String, String) {
    let averaged = format!(
        "{} honest and {} Byzantine models averaged",
        c["aggregated_honest"].as_u64().unwrap_or(0),
        c["aggregated_byzantine"].as_u64().unwrap_or(0)
    );
    let submissions = &c["submissions"];
    let mut written = submissions["accepted"].as_u64().unwrap_or(0).to_string();
    if let Some(d) = submissions["duplicate"].as_u64().filter(|d| *d > 0) {
        written.push_str(&format!(" ({d} duplicates dropped)"));
    }
    (averaged, written)
}

/// A gossip run's merges (of honest robots), the models they averaged, the held-out loss of
/// the honest robots' final models and the radio's bytes and messages. No chain, contract or
/// tokens exist here, so none are shown.
fn gossip_lines(s: &serde_json::Value, out: &mut Vec<String>) {
    let (c, a) = (&s["contract"], &s["aggregation"]);
    let (averaged, written) = baseline_models(c);
    out.push(
        "aggregation: gossip (Flow-FL: a virtual-stigmergy store shared by neighbour gossip; no \
         chain, contract or tokens)"
            .to_string(),
    );
    out.push(format!(
        "merges:     {} by honest robots, {averaged}; loss by merge:{}",
        c["rounds"].as_u64().unwrap_or(0),
        loss_points(c, "#")
    ));
    out.push(format!(
        "            held-out loss {} -> {} (mean over the honest robots' final models); models \
         written {written}",
        loss(&c["heldout_loss_initial"]),
        loss(&c["final_heldout_loss"]),
    ));
    out.push(format!(
        "radio:      sent {} MB/robot, stored {} MB/robot (its replica); messages {} sent, {} \
         lost",
        mb(&a["bytes_sent_per_robot_mean"]),
        mb(&a["bytes_stored_per_robot_mean"]),
        a["messages_sent"],
        a["messages_lost"]
    ));
}

/// A central run's server aggregations (each a model version), the models they averaged, the
/// held-out loss of the server's model and the bytes uploaded, downloaded and stored. No
/// chain, contract or tokens exist here, so none are shown.
fn central_lines(s: &serde_json::Value, out: &mut Vec<String>) {
    let (c, a) = (&s["contract"], &s["aggregation"]);
    let (averaged, written) = baseline_models(c);
    let versions = c["rounds"].as_u64().unwrap_or(0);
    out.push(
        "aggregation: central (an ideal server: FedAvg of every upload; no chain, contract or \
         tokens)"
            .to_string(),
    );
    out.push(format!(
        "server:     {versions} aggregations (model versions 1..{versions}), {averaged}; loss \
         by version:{}",
        loss_points(c, "v")
    ));
    out.push(format!(
        "            held-out loss {} -> {} (the server's model); uploads {written}",
        loss(&c["heldout_loss_initial"]),
        loss(&c["final_heldout_loss"]),
    ));
    out.push(format!(
        "traffic:    uploaded {} MB/robot, downloaded {} MB/robot, stored {} MB/robot",
        mb(&a["bytes_sent_per_robot_mean"]),
        mb(&a["bytes_downloaded_per_robot_mean"]),
        mb(&a["bytes_stored_per_robot_mean"])
    ));
}

/// The `timing` object of a summary as one line of seconds, wall (CPU): the parts in the
/// order they run, each `name W s (C s CPU)`; `summary.json` keeps the full numbers. The
/// driver's ledger part is a baseline's aggregation protocol (`kind`), and is named so.
fn timing_line(timing: &serde_json::Value, kind: Aggregation) -> String {
    let Some(map) = timing.as_object() else {
        return "-".to_string();
    };
    let protocol = match kind {
        Aggregation::Chain => "ledger",
        Aggregation::Gossip | Aggregation::Central => "aggregation",
    };
    let mut parts = Vec::new();
    for (name, label) in [
        ("world", "world"),
        ("ledger", protocol),
        ("learning", "learning"),
        ("checkpoint", "checkpoints"),
        ("log_and_summary", "log"),
    ] {
        let wall = map.get(&format!("{name}_s")).and_then(|v| v.as_f64());
        let cpu = map.get(&format!("{name}_cpu_s")).and_then(|v| v.as_f64());
        if let Some(wall) = wall {
            parts.push(match cpu {
                Some(cpu) => format!("{label} {wall:.2} s ({cpu:.2} s CPU)"),
                None => format!("{label} {wall:.2} s"),
            });
        }
    }
    parts.join(", ")
}

/// Prints what to do next with a finished run's log, with the command spelled the way this
/// shell can run it (see [`program_name`]).
pub fn print_next(outcome: &RunOutcome) {
    let me = program_name();
    print!("{}", next_text(&outcome.summary, &outcome.log_path, &me));
    if me != "swarmfl" {
        println!("  (`cargo install --path replay-cli --locked` puts `swarmfl` on your PATH)");
    }
}

/// What to do next with the run of `summary` logged at `log`, spelled with the program `me`:
/// view, replay, and inspect halfway through: at the block halfway up the final chain, or for
/// a baseline (no blocks) at half its simulated time.
pub fn next_text(summary: &serde_json::Value, log: &Path, me: &str) -> String {
    let html = log.with_file_name("run.html");
    let log = log.display();
    let inspect = match aggregation_kind(summary) {
        Aggregation::Chain => {
            let height = summary["ledger"]["canonical_height"].as_u64().unwrap_or(0) / 2;
            format!(
                "{me} inspect {log} --block {height}   # the chain, contract and robots at a block"
            )
        }
        Aggregation::Gossip | Aggregation::Central => {
            let half_s = (summary["sim_time_s"].as_f64().unwrap_or(0.0) / 2.0).floor();
            format!(
                "{me} inspect {log} --time {half_s}   # the models, losses and bytes at a time (no \
                 chain: no blocks)"
            )
        }
    };
    format!(
        "\nnext:\n  {me} view {log} --out {}   # watch it in a browser\n  {me} replay {log}            \
         # check its hash chain and checkpoints (--resimulate: re-make every record)\n  {inspect}\n",
        html.display()
    )
}

/// `swarmfl` when that name on the PATH is this very program, else the path this process was
/// started by (`target/release/swarmfl` under `cargo run`), so every hint can be pasted as is.
fn program_name() -> String {
    let me = std::env::current_exe()
        .ok()
        .and_then(|p| p.canonicalize().ok());
    let on_path = std::env::var_os("PATH").is_some_and(|paths| {
        std::env::split_paths(&paths).any(|dir| {
            let candidate = dir.join("swarmfl").canonicalize().ok();
            candidate.is_some() && candidate == me
        })
    });
    if on_path {
        return "swarmfl".to_string();
    }
    std::env::args()
        .next()
        .filter(|a| a.contains('/'))
        .or_else(|| me.map(|p| p.display().to_string()))
        .unwrap_or_else(|| "swarmfl".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A summary as `summary.json` holds it (the figures of a 600 s smoke run) with the
    /// aggregation `kind`'s own figures.
    fn summary(kind: &str) -> serde_json::Value {
        let baseline = kind != "chain";
        serde_json::json!({
            "preset": "smoke", "seed": 7, "robots": 15, "sim_time_s": 600.0,
            "records": 8743, "log_bytes": 1902139,
            "world": {"collisions": 0, "mean_neighbours": 4.38,
                      "samples_per_robot_per_600s": 230.4},
            "contract": {
                "rounds": if baseline { 12 } else { 34 },
                "loss_by_round": vec![1.75; if baseline { 12 } else { 34 }],
                "heldout_loss_initial": 3.0719, "final_heldout_loss": 2.0781,
                "submissions": if baseline {
                    serde_json::json!({"accepted": 87, "duplicate": 2})
                } else {
                    serde_json::json!({"accepted": 80, "outlier": 3})
                },
                "mean_honest_distance": if baseline { serde_json::Value::Null } else { 0.01.into() },
                "outlier_threshold": 0.05, "aggregated_honest": 84, "aggregated_byzantine": 1,
            },
            "tokens": {"honest_mean_gain": 0.0, "byzantine_mean_gain": null,
                       "total_units_start": 315, "total_units_end": 315},
            "aggregation": {
                "kind": kind, "conservation": "not applicable",
                "bytes_sent_per_robot_mean": 1157000.0, "bytes_stored_per_robot_mean": 214000.0,
                "bytes_downloaded_per_robot_mean": 85000.0,
                "messages_sent": 4321, "messages_lost": 12,
            },
            "ledger": {"canonical_height": if baseline { 0 } else { 34 }, "forks": 0,
                       "reorgs": 0, "deepest_reorg": 0, "tx_delay_median_s": 0.0,
                       "tx_delay_p95_s": 0.0, "bytes_per_submission": 0.0},
            "timing": {"world_s": 0.15, "ledger_s": 0.06},
            "final_hash": "f7182768053f1de713500eb01b33fef473e1f9577f1e33703a501c9a8476a708",
            "wall_s": 2.66,
        })
    }

    /// The summary and the next steps of `kind`'s summary, as `run` prints them.
    fn printed(kind: &str) -> String {
        let log = Path::new("runs/x/run.swlog");
        summary_text(&summary(kind), log, 0) + &next_text(&summary(kind), log, "swarmfl")
    }

    #[test]
    fn a_baselines_summary_says_what_it_has_and_nothing_of_a_chain() {
        for kind in ["gossip", "central"] {
            let text = printed(kind);
            for chain_only in [
                "contract:",
                "rounds",
                "tokens:",
                "canonical height",
                "--block",
                "ledger",
            ] {
                assert!(
                    !text.contains(chain_only),
                    "{kind}: {chain_only} in\n{text}"
                );
            }
            assert!(text.contains("no chain, contract or tokens"), "{text}");
            assert!(
                text.contains("84 honest and 1 Byzantine models averaged"),
                "{text}"
            );
            assert!(text.contains("held-out loss 3.0719 -> 2.0781"), "{text}");
            assert!(text.contains("87 (2 duplicates dropped)"), "{text}");
            assert!(
                text.contains("timing:     world 0.15 s, aggregation 0.06 s"),
                "{text}"
            );
            assert!(
                text.contains("swarmfl inspect runs/x/run.swlog --time 300   #"),
                "{text}"
            );
        }
        let gossip = printed("gossip");
        assert!(gossip.contains("aggregation: gossip (Flow-FL"), "{gossip}");
        assert!(
            gossip.contains("merges:     12 by honest robots"),
            "{gossip}"
        );
        assert!(
            gossip.contains("loss by merge: #1=1.7500 #10=1.7500 #12=1.7500"),
            "{gossip}"
        );
        assert!(
            gossip.contains("radio:      sent 1.157 MB/robot, stored 0.214 MB/robot (its replica); messages 4321 sent, 12 lost"),
            "{gossip}"
        );
        let central = printed("central");
        assert!(
            central.contains("server:     12 aggregations (model versions 1..12)"),
            "{central}"
        );
        assert!(
            central.contains("traffic:    uploaded 1.157 MB/robot, downloaded 0.085 MB/robot, stored 0.214 MB/robot"),
            "{central}"
        );
    }

    #[test]
    fn a_chain_runs_summary_keeps_its_contract_tokens_and_ledger() {
        let text = printed("chain");
        assert!(
            text.contains(
                "contract:   34 rounds; loss by round: r1=1.7500 r10=1.7500 r25=1.7500 r34=1.7500"
            ),
            "{text}"
        );
        assert!(
            text.contains("tokens:     honest mean gain 0.0000"),
            "{text}"
        );
        assert!(text.contains("ledger:     canonical height 34"), "{text}");
        assert!(
            text.contains("timing:     world 0.15 s, ledger 0.06 s"),
            "{text}"
        );
        assert!(
            text.contains("swarmfl inspect runs/x/run.swlog --block 17   #"),
            "{text}"
        );
        // A summary from before the baselines has no aggregation section: a chain run's.
        let mut old = summary("chain");
        old.as_object_mut().unwrap().remove("aggregation");
        let text = summary_text(&old, Path::new("run.swlog"), 0);
        assert!(text.contains("canonical height 34"), "{text}");
    }

    #[test]
    fn timing_reads_as_seconds_in_the_order_the_parts_run() {
        let timing = serde_json::json!({
            "world_s": 1.5130919520000006, "world_cpu_s": 1.4992536579999949,
            "learning_s": 16.93136347900006, "learning_cpu_s": 30.87294149599976,
        });
        assert_eq!(
            timing_line(&timing, Aggregation::Chain),
            "world 1.51 s (1.50 s CPU), learning 16.93 s (30.87 s CPU)"
        );
    }
}

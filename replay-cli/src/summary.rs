//! A run's summary as the command prints it (`run` and `fork`): the short human text of
//! `summary.json` and what to try next with the log.

use std::path::Path;

use swarmfl_core::config::Aggregation;
use swarmfl_core::metrics::ContractSummary;
use swarmfl_core::summary::RunSummary;
use swarmfl_study::run::RunOutcome;
use swarmfl_study::summary::{count, Summary, Timing};

/// Prints the short human summary of a run ([`summary_text`]).
pub fn print_summary(outcome: &RunOutcome) {
    print!(
        "{}",
        summary_text(&outcome.summary, &outcome.log_path, outcome.sealings)
    );
}

/// A number as `summary.json` writes it (`600.0`, `0.05`; `null` when not finite), so the
/// text shows the figures as the file does.
fn json(x: f64) -> String {
    serde_json::Value::from(x).to_string()
}

/// A number the file holds (`None` when not finite: the file holds it as `null`).
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// A loss as `run` prints it: four decimals, `-` when there is none.
fn loss(v: Option<f64>) -> String {
    v.and_then(finite)
        .map_or("-".to_string(), |x| format!("{x:.4}"))
}

/// Megabytes with three decimals, `-` when there are none.
fn mb(bytes: f64) -> String {
    finite(bytes).map_or("-".to_string(), |x| format!("{:.3}", x / 1e6))
}

/// The losses at aggregations 1, 10, 25, 50 and the last, as ` {p}1=... {p}10=...`.
fn loss_points(contract: &ContractSummary, prefix: &str) -> String {
    let rounds = contract.rounds;
    let losses = &contract.loss_by_round;
    let mut shown = String::new();
    for r in [1u64, 10, 25, 50, rounds] {
        let label = format!("{prefix}{r}=");
        if r >= 1 && r <= rounds && !shown.contains(&format!(" {label}")) {
            let value = losses.get((r - 1) as usize).copied();
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
pub fn summary_text(summary: &Summary, log: &Path, sealings: u64) -> String {
    let s = &summary.run;
    let kind = s.aggregation.kind;
    let world = &s.world;
    let mut out = vec![
        format!("log:        {}", log.display()),
        format!(
            "run:        preset {} seed {}, {} robots, {} simulated s",
            s.preset,
            s.seed,
            s.robots,
            json(s.sim_time_s)
        ),
        format!("records:    {} ({} bytes)", s.records, summary.log_bytes),
        format!(
            "world:      collisions {}, mean neighbours {:.2}, samples/robot/600 s {:.1}",
            world.collisions,
            finite(world.mean_neighbours).unwrap_or(0.0),
            finite(world.samples_per_robot_per_600s).unwrap_or(0.0)
        ),
    ];
    match kind {
        Aggregation::Chain => chain_lines(s, sealings, &mut out),
        Aggregation::Gossip => gossip_lines(s, &mut out),
        Aggregation::Central | Aggregation::Matched => central_lines(s, &mut out),
    }
    if let Some(gas) = &summary.evm_gas {
        let mean = |kind: &str| gas.get(kind).map_or("-".into(), |g| g.mean_gas.to_string());
        out.push(format!(
            "evm gas:    submission {} (mean), aggregating submission {}, outlier {}, deploy {}; \
             contract wall time is inside ledger_s below",
            mean("accepted"),
            mean("aggregated"),
            mean("outlier"),
            mean("deploy")
        ));
    }
    out.push(format!(
        "timing:     {}",
        timing_line(&summary.timing, kind)
    ));
    out.push(format!("final hash: {}", s.final_hash));
    out.push(format!(
        "wall time:  {:.2} s",
        finite(summary.wall_s).unwrap_or(0.0)
    ));
    out.join("\n") + "\n"
}

/// A chain run's contract, tokens, aggregation traffic and ledger.
fn chain_lines(s: &RunSummary, sealings: u64, out: &mut Vec<String>) {
    let c = &s.contract;
    out.push(format!(
        "contract:   {} rounds; loss by round:{}",
        c.rounds,
        loss_points(c, "r")
    ));
    out.push(format!(
        "            held-out loss {} -> {}; submissions {}",
        loss(Some(c.heldout_loss_initial)),
        loss(c.final_heldout_loss),
        serde_json::to_string(&c.submissions).unwrap_or_default()
    ));
    out.push(format!(
        "            mean honest distance {} (outlier threshold {})",
        loss(c.mean_honest_distance),
        json(c.outlier_threshold)
    ));
    let t = &s.tokens;
    out.push(format!(
        "tokens:     honest mean gain {}, Byzantine mean gain {}, total units {} -> {}",
        loss(t.honest_mean_gain),
        loss(t.byzantine_mean_gain),
        t.total_units_start,
        t.total_units_end
    ));
    if let Some(held) = finite(t.contract_holdings).filter(|h| *h > 0.0) {
        // Without this a clean run's negative gain reads as a loss: it is stake still locked.
        out.push(format!(
            "            (gains count {held:.3} tokens as spent: the stakes the contract still \
             holds for the round open at the end)"
        ));
    }
    let a = &s.aggregation;
    out.push(format!(
        "aggregation: {}; sent {} MB/robot, stored {} MB/robot; conservation {}",
        a.kind.name(),
        mb(a.bytes_sent_per_robot_mean),
        mb(a.bytes_stored_per_robot_mean),
        a.conservation
    ));
    let l = &s.ledger;
    out.push(format!(
        "ledger:     canonical height {} (blocks of the final chain, genesis apart), {} \
         sealings on all forks (every block any node sealed, as `replay`, `view` and `export` \
         count them), forks {}, reorgs {} (deepest {}), tx delay median {} s p95 {} s, {:.0} \
         B/submission",
        l.canonical_height,
        sealings,
        l.forks,
        l.reorgs,
        l.deepest_reorg,
        json(l.tx_delay_median_s),
        json(l.tx_delay_p95_s),
        finite(l.bytes_per_submission).unwrap_or(0.0)
    ));
}

/// What a baseline's summary says about the models it averaged: `N honest and M Byzantine
/// models averaged`, and the models written (`accepted`, with the duplicates dropped if any).
/// The summary's `contract` section holds a baseline's figures under the chain's names.
fn baseline_models(c: &ContractSummary) -> (String, String) {
    let averaged = format!(
        "{} honest and {} Byzantine models averaged",
        c.aggregated_honest, c.aggregated_byzantine
    );
    let mut written = count(&c.submissions, "accepted").unwrap_or(0).to_string();
    if let Some(d) = count(&c.submissions, "duplicate").filter(|d| *d > 0) {
        written.push_str(&format!(" ({d} duplicates dropped)"));
    }
    (averaged, written)
}

/// A gossip run's merges (of honest robots), the models they averaged, the held-out loss of
/// the honest robots' final models and the radio's bytes and messages. No chain, contract or
/// tokens exist here, so none are shown.
fn gossip_lines(s: &RunSummary, out: &mut Vec<String>) {
    let (c, a) = (&s.contract, &s.aggregation);
    let (averaged, written) = baseline_models(c);
    out.push(
        "aggregation: gossip (Flow-FL: a virtual-stigmergy store shared by neighbour gossip; no \
         chain, contract or tokens)"
            .to_string(),
    );
    out.push(format!(
        "merges:     {} by honest robots, {averaged}; loss by merge:{}",
        c.rounds,
        loss_points(c, "#")
    ));
    out.push(format!(
        "            held-out loss {} -> {} (mean over the honest robots' final models); models \
         written {written}",
        loss(Some(c.heldout_loss_initial)),
        loss(c.final_heldout_loss),
    ));
    out.push(format!(
        "radio:      sent {} MB/robot, stored {} MB/robot (its replica); messages {} sent, {} \
         lost",
        mb(a.bytes_sent_per_robot_mean),
        mb(a.bytes_stored_per_robot_mean),
        a.messages_sent,
        a.messages_lost
    ));
}

/// A central run's server aggregations (each a model version), the models they averaged, the
/// held-out loss of the server's model and the bytes uploaded, downloaded and stored. No
/// chain, contract or tokens exist here, so none are shown.
fn central_lines(s: &RunSummary, out: &mut Vec<String>) {
    let (c, a) = (&s.contract, &s.aggregation);
    let (averaged, written) = baseline_models(c);
    let versions = c.rounds;
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
        loss(Some(c.heldout_loss_initial)),
        loss(c.final_heldout_loss),
    ));
    out.push(format!(
        "traffic:    uploaded {} MB/robot, downloaded {} MB/robot, stored {} MB/robot",
        mb(a.bytes_sent_per_robot_mean),
        mb(a.bytes_downloaded_per_robot_mean),
        mb(a.bytes_stored_per_robot_mean)
    ));
}

/// The `timing` of a summary as one line of seconds, wall (CPU): the parts in the order they
/// run, each `name W s (C s CPU)` (a part whose wall time is not a number left out, its CPU
/// time when that is not); `summary.json` keeps the full numbers. The driver's ledger part is
/// a baseline's aggregation protocol (`kind`), and is named so.
fn timing_line(timing: &Timing, kind: Aggregation) -> String {
    let protocol = match kind {
        Aggregation::Chain => "ledger",
        Aggregation::Gossip | Aggregation::Central | Aggregation::Matched => "aggregation",
    };
    let labels = ["world", protocol, "learning", "checkpoints", "log"];
    let mut parts = Vec::new();
    for (label, (wall, cpu)) in labels.into_iter().zip(timing.parts()) {
        if let Some(wall) = finite(wall) {
            parts.push(match finite(cpu) {
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
pub fn next_text(summary: &Summary, log: &Path, me: &str) -> String {
    let html = log.with_file_name("run.html");
    let log = log.display();
    let run = &summary.run;
    let inspect = match run.aggregation.kind {
        Aggregation::Chain => {
            let height = run.ledger.canonical_height / 2;
            format!(
                "{me} inspect {log} --block {height}   # the chain, contract and robots at a block"
            )
        }
        Aggregation::Gossip | Aggregation::Central | Aggregation::Matched => {
            let half_s = (finite(run.sim_time_s).unwrap_or(0.0) / 2.0).floor();
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

    /// A summary with the figures of a 600 s smoke run (every figure `run` does not print a
    /// reduced-study run's) and the aggregation `kind`'s own figures.
    fn summary(kind: Aggregation) -> Summary {
        let baseline = kind != Aggregation::Chain;
        let file = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../reproduction/reduced-study/results/e1-faulty/faulty-1/seed1.json");
        let mut summary = Summary::read(&file).unwrap();
        let s = &mut summary.run;
        (s.preset, s.seed, s.robots, s.sim_time_s) = ("smoke".into(), 7, 15, 600.0);
        s.records = 8743;
        s.world.collisions = 0;
        s.world.mean_neighbours = 4.38;
        s.world.samples_per_robot_per_600s = 230.4;
        let c = &mut s.contract;
        c.rounds = if baseline { 12 } else { 34 };
        c.loss_by_round = vec![1.75; c.rounds as usize];
        (c.heldout_loss_initial, c.final_heldout_loss) = (3.0719, Some(2.0781));
        let submissions: &[(&str, u64)] = if baseline {
            &[("accepted", 87), ("duplicate", 2)]
        } else {
            &[("accepted", 80), ("outlier", 3)]
        };
        c.submissions = submissions
            .iter()
            .map(|(k, n)| (k.to_string(), *n))
            .collect();
        c.mean_honest_distance = (!baseline).then_some(0.01);
        c.outlier_threshold = 0.05;
        (c.aggregated_honest, c.aggregated_byzantine) = (84, 1);
        let t = &mut s.tokens;
        (t.honest_mean_gain, t.byzantine_mean_gain) = (Some(0.0), None);
        (t.total_units_start, t.total_units_end) = (315, 315);
        t.contract_holdings = 0.0;
        let a = &mut s.aggregation;
        (a.kind, a.conservation) = (kind, "not applicable".into());
        a.bytes_sent_per_robot_mean = 1157000.0;
        a.bytes_stored_per_robot_mean = 214000.0;
        a.bytes_downloaded_per_robot_mean = 85000.0;
        (a.messages_sent, a.messages_lost) = (4321, 12);
        let l = &mut s.ledger;
        l.canonical_height = if baseline { 0 } else { 34 };
        (l.forks, l.reorgs, l.deepest_reorg) = (0, 0, 0);
        (
            l.tx_delay_median_s,
            l.tx_delay_p95_s,
            l.bytes_per_submission,
        ) = (0.0, 0.0, 0.0);
        s.final_hash = "f7182768053f1de713500eb01b33fef473e1f9577f1e33703a501c9a8476a708".into();
        // Two parts timed, the others not numbers (left out).
        summary.timing = Timing {
            world_s: 0.15,
            ledger_s: 0.06,
            ..nan_timing()
        };
        (summary.wall_s, summary.log_bytes) = (2.66, 1902139);
        summary
    }

    /// A timing without a number.
    fn nan_timing() -> Timing {
        let n = f64::NAN;
        Timing {
            world_s: n,
            ledger_s: n,
            learning_s: n,
            checkpoint_s: n,
            log_and_summary_s: n,
            world_cpu_s: n,
            ledger_cpu_s: n,
            learning_cpu_s: n,
            checkpoint_cpu_s: n,
            log_and_summary_cpu_s: n,
        }
    }

    /// The summary and the next steps of `kind`'s summary, as `run` prints them.
    fn printed(kind: Aggregation) -> String {
        let log = Path::new("runs/x/run.swlog");
        summary_text(&summary(kind), log, 0) + &next_text(&summary(kind), log, "swarmfl")
    }

    #[test]
    fn a_baselines_summary_says_what_it_has_and_nothing_of_a_chain() {
        for kind in [Aggregation::Gossip, Aggregation::Central] {
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
                    "{kind:?}: {chain_only} in\n{text}"
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
        let gossip = printed(Aggregation::Gossip);
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
        let central = printed(Aggregation::Central);
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
        let text = printed(Aggregation::Chain);
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
        let mut old = serde_json::to_value(summary(Aggregation::Chain)).unwrap();
        old.as_object_mut().unwrap().remove("aggregation");
        let old: Summary = serde_json::from_value(old).unwrap();
        let text = summary_text(&old, Path::new("run.swlog"), 0);
        assert!(text.contains("canonical height 34"), "{text}");
    }

    #[test]
    fn timing_reads_as_seconds_in_the_order_the_parts_run() {
        let timing = Timing {
            world_s: 1.5130919520000006,
            world_cpu_s: 1.4992536579999949,
            learning_s: 16.93136347900006,
            learning_cpu_s: 30.87294149599976,
            ..nan_timing()
        };
        assert_eq!(
            timing_line(&timing, Aggregation::Chain),
            "world 1.51 s (1.50 s CPU), learning 16.93 s (30.87 s CPU)"
        );
    }
}

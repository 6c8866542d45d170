//! `swarmfl inspect`: a run at one block of its final canonical chain (or, for a baseline run,
//! at a time).

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use swarmfl_core::inspect::{self, timeline, BlockReport, SubmissionInfo};
use swarmfl_core::RobotId;

use crate::cli::InspectArgs;
use crate::progress::warn_if_truncated;

/// Runs `swarmfl inspect`: `--block H`, or `--time T` for a baseline run.
pub fn command(args: InspectArgs) -> anyhow::Result<ExitCode> {
    let InspectArgs {
        log,
        block,
        time,
        robot,
        json,
        no_index,
    } = args;
    match (block, time) {
        (Some(block), _) => inspect(&log, block, robot, json, !no_index)?,
        (None, Some(time)) => inspect_time(&log, time, json)?,
        (None, None) => anyhow::bail!("give --block HEIGHT or --time SECONDS"),
    }
    Ok(ExitCode::SUCCESS)
}

/// Prints block `height` of the log (human-readable or JSON) and the time it took.
/// With `use_index`, a valid sidecar `LOG.idx` lets it fold only up to the block; without one,
/// the whole log is folded and the sidecar written for next time.
fn inspect(
    log: &Path,
    height: u64,
    robot: Option<RobotId>,
    json: bool,
    use_index: bool,
) -> anyhow::Result<()> {
    let start = Instant::now();
    let sidecar = if use_index {
        inspect::read_sidecar(log)
    } else {
        None
    };
    let (report, last, how) = match &sidecar {
        Some(sidecar) => (
            inspect::block_report_indexed(log, sidecar, height, robot)?,
            sidecar.blocks.len() as u64 - 1,
            "folded up to the block, using the sidecar index",
        ),
        None => {
            let index = inspect::index_run(log, Some(height))?;
            warn_if_truncated(&index);
            let report = inspect::block_report(&index, height, robot)?;
            let how = if index.truncated.is_some() {
                "folded the intact prefix of a truncated log"
            } else if !use_index {
                "folded the whole log"
            } else {
                match index
                    .sidecar(log)
                    .map_err(anyhow::Error::from)
                    .and_then(|s| {
                        let path = inspect::sidecar_path(log);
                        std::fs::write(&path, serde_json::to_string(&s)?)?;
                        Ok(path)
                    }) {
                    Ok(_) => "folded the whole log; wrote the sidecar index for next time",
                    Err(e) => {
                        eprintln!(
                            "note: cannot write the sidecar index {}: {e:#}",
                            inspect::sidecar_path(log).display()
                        );
                        "folded the whole log"
                    }
                }
            };
            (report, index.last_height(), how)
        }
    };
    let took_ms = start.elapsed().as_secs_f64() * 1000.0;
    if json {
        let mut value = serde_json::to_value(&report)?;
        value["inspect_ms"] = serde_json::json!(took_ms);
        value["last_height"] = serde_json::json!(last);
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print_report(&report, last);
        println!("inspect took {took_ms:.0} ms ({how})");
    }
    Ok(())
}

/// The first characters of a hash, enough to tell blocks apart.
fn short(hex: &str) -> &str {
    &hex[..hex.len().min(12)]
}

/// A robot's kind as a word.
fn mark(byzantine: bool) -> &'static str {
    if byzantine {
        "byzantine"
    } else {
        "honest"
    }
}

/// One line per counted submission: sender, samples, distance, stake and verdict.
fn print_submissions(subs: &[SubmissionInfo]) {
    for s in subs {
        println!(
            "    robot {:>3} ({:<9}) n={:<5} distance {:>10.6} per weight  stake {:.3}  {}",
            s.sender,
            mark(s.byzantine),
            s.samples,
            s.distance_per_weight,
            s.stake_tokens,
            s.verdict
        );
    }
}

/// The human-readable report of one block (`last` is the final chain's height).
fn print_report(r: &BlockReport, last: u64) {
    print_block(r, last);
    print_contract(r);
    print_nodes(r);
    print_world(r);
    print_robot_view(r);
}

/// The block: hash, parent, time, signer, difficulty and its transactions.
fn print_block(r: &BlockReport, last: u64) {
    let b = &r.block;
    println!(
        "block {} of {} (final canonical chain of {})",
        b.height, last, r.log
    );
    println!("  hash        {}", b.hash);
    println!("  parent      {}", b.parent);
    println!("  time        {:.3} s", b.time_s);
    match b.signer {
        Some(s) => println!("  signer      robot {s}"),
        None => println!("  signer      none (genesis)"),
    }
    println!(
        "  difficulty  {} (total {}), chain size {} bytes, sealing record {}",
        b.difficulty,
        b.total_difficulty,
        b.chain_bytes,
        b.record.map_or("-".to_string(), |i| i.to_string())
    );
    println!("  transactions: {}", b.txs.len());
    for t in &b.txs {
        println!(
            "    {} robot {:>3} ({:<9}) {:<22} value {:.3} -> {} {}",
            short(&t.hash),
            t.sender,
            mark(t.byzantine),
            t.call,
            t.value_tokens,
            t.outcome,
            t.detail
        );
    }
}

/// The contract after the block: rounds, pool, balances, submissions, the last round's payouts.
fn print_contract(r: &BlockReport) {
    let c = &r.contract;
    println!("contract after the block");
    println!(
        "  {} rounds closed, round {} open; model version {} {}",
        c.round,
        c.round + 1,
        c.round,
        short(&c.model_digest)
    );
    println!("  pool (contract holdings) {:.3} tokens", c.pool_tokens);
    println!("  balances (tokens):");
    for chunk in c.balances.chunks(5) {
        let line: Vec<String> = chunk
            .iter()
            .map(|x| {
                format!(
                    "{:>3}{} {:>9.3}",
                    x.robot,
                    if x.byzantine { "*" } else { " " },
                    x.tokens
                )
            })
            .collect();
        println!("   {}", line.join("  "));
    }
    println!("   (* = Byzantine)");
    println!(
        "  this round's counted submissions: {}",
        c.submissions.len()
    );
    print_submissions(&c.submissions);
    match &c.last_round {
        None => println!("  no round closed yet"),
        Some(l) => {
            println!(
                "  last closed round {}: pool {:.3} tokens, carried {:.3}, {} submissions",
                l.round,
                l.pool_tokens,
                l.carried_tokens,
                l.submissions.len()
            );
            print_submissions(&l.submissions);
            for (robot, rank, weight, tokens) in &l.payouts {
                println!(
                    "    payout rank {rank:>2}: robot {robot:>3} (weight {weight:+}) {tokens:.3} tokens"
                );
            }
        }
    }
}

/// Every node's head right after the sealing.
fn print_nodes(r: &BlockReport) {
    println!("nodes right after the sealing");
    for n in &r.nodes {
        println!(
            "  node {:>3}: head {} height {:>5}{}",
            n.node,
            short(&n.head),
            n.height,
            if n.on_final_chain {
                ""
            } else {
                "  (off the final chain)"
            }
        );
    }
}

/// Every robot's pose, peers and data set at that moment.
fn print_world(r: &BlockReport) {
    println!("world at t = {:.3} s", r.world.time_s);
    for w in &r.world.robots {
        println!(
            "  robot {:>3} ({:<9}) at ({:6.3}, {:6.3}) heading {:6.3} rad, {:>2} peers, {:>4} samples",
            w.robot,
            mark(w.byzantine),
            w.x,
            w.y,
            w.theta,
            w.peers,
            w.dataset
        );
    }
}

/// With `--robot`, that robot's view: its node, balance, data and last learning phase.
fn print_robot_view(r: &BlockReport) {
    if let Some(v) = &r.robot {
        println!("robot {} ({}) view", v.robot, mark(v.byzantine));
        println!(
            "  its node's head {} at height {} ({}), {} rounds closed there, its balance {:.3} tokens",
            short(&v.node.head),
            v.node.height,
            if v.node.on_final_chain {
                "on the final chain"
            } else {
                "off the final chain"
            },
            v.round,
            v.balance_tokens
        );
        println!(
            "  at ({:.3}, {:.3}), {} samples, peers {:?}",
            v.world.x, v.world.y, v.world.dataset, v.peers
        );
        match &v.last_learning {
            Some((t, what)) => println!("  last learning phase at {t:.3} s: {what}"),
            None => println!("  no learning phase yet"),
        }
    }
}

/// `inspect --time T` of a baseline run: each robot's replica, bytes and model at the last
/// checkpoint at or before T.
fn inspect_time(log: &Path, time_s: f64, json: bool) -> anyhow::Result<()> {
    anyhow::ensure!(
        time_s.is_finite() && time_s >= 0.0,
        "--time must be a non-negative number of seconds, got {time_s}"
    );
    let start = Instant::now();
    let r = timeline::report_at(log, swarmfl_core::SimTime::from_secs(time_s))?;
    let took_ms = start.elapsed().as_secs_f64() * 1000.0;
    if json {
        let mut value = serde_json::to_value(&r)?;
        value["inspect_ms"] = serde_json::json!(took_ms);
        println!("{}", serde_json::to_string_pretty(&value)?);
        return Ok(());
    }
    println!(
        "t = {:.1} s ({} aggregation): {} aggregations, last loss {:.5}, held-out loss {:.5} (mean over honest robots)",
        r.time_s,
        r.aggregation.name(),
        r.round,
        r.loss,
        r.heldout_loss
    );
    for robot in &r.robots {
        let entries: Vec<String> = robot
            .entries
            .iter()
            .map(|(k, c)| format!("{k}:{c}"))
            .collect();
        println!(
            "  robot {:>3} ({:<9}) held-out {:.5}  sent {:>10} B  entries [{}]",
            robot.robot,
            mark(robot.byzantine),
            robot.heldout_loss,
            robot.bytes_sent,
            entries.join(" ")
        );
    }
    println!("inspect took {took_ms:.0} ms");
    Ok(())
}

//! `swarmfl export`: CSV tables of a run, from one fold of its log.

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use swarmfl_core::inspect::{self, expr::Env};

use crate::cli::ExportArgs;
use crate::commands::inspect::warn_if_truncated;

/// Runs `swarmfl export`.
pub fn command(args: ExportArgs) -> anyhow::Result<ExitCode> {
    export(&args.log, &args.out)?;
    Ok(ExitCode::SUCCESS)
}

/// Writes `rounds.csv`, `balances.csv`, `chain_bytes.csv` and `trajectories.csv` into `out`.
pub fn export(log: &Path, out: &Path) -> anyhow::Result<()> {
    let start = Instant::now();
    let index = inspect::index_run(log, None)?;
    warn_if_truncated(&index);
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let open = |name: &str| -> anyhow::Result<Csv> {
        let path = out.join(name);
        csv::Writer::from_path(&path).with_context(|| format!("cannot write {}", path.display()))
    };
    let rounds = write_rounds(&index, open("rounds.csv")?)?;
    write_balances(&index, open("balances.csv")?)?;
    write_chain_bytes(&index, open("chain_bytes.csv")?)?;
    let samples = write_trajectories(&index, open("trajectories.csv")?)?;
    println!(
        "wrote {}: rounds.csv ({} rounds), balances.csv ({} blocks x {} robots), chain_bytes.csv ({} sealings), trajectories.csv ({} samples of the final data sets) in {:.0} ms",
        out.display(),
        rounds,
        index.chain.len(),
        index.config.world.robots,
        index.chain_bytes.len(),
        samples,
        start.elapsed().as_secs_f64() * 1000.0
    );
    Ok(())
}

/// A CSV file being written.
type Csv = csv::Writer<std::fs::File>;

/// Per closed round of the final canonical chain; returns the number of rounds.
fn write_rounds(index: &inspect::RunIndex, mut w: Csv) -> anyhow::Result<usize> {
    let values = index.values();
    w.write_record([
        "round",
        "block",
        "time_s",
        "loss",
        "heldout_loss",
        "accepted",
        "outliers",
        "mean_honest_distance",
    ])?;
    let rounds = index.rounds();
    for r in &rounds {
        let heldout = values.at(r.block).ident("heldout_loss")?;
        w.write_record([
            r.round.to_string(),
            r.block.to_string(),
            r.time_s.to_string(),
            r.loss.to_string(),
            heldout.to_string(),
            r.accepted.to_string(),
            r.outliers.to_string(),
            r.mean_honest_distance.to_string(),
        ])?;
    }
    w.flush()?;
    Ok(rounds.len())
}

/// Every robot's balance after every block of the final canonical chain.
fn write_balances(index: &inspect::RunIndex, mut w: Csv) -> anyhow::Result<()> {
    w.write_record(["block", "time_s", "robot", "balance_tokens", "byzantine"])?;
    for row in &index.chain {
        let state = index.contract_at(row.height);
        for (robot, &units) in state.balances.iter().enumerate() {
            w.write_record([
                row.height.to_string(),
                row.time.secs().to_string(),
                robot.to_string(),
                index.tokens(units).to_string(),
                index.byzantine[robot].to_string(),
            ])?;
        }
    }
    w.flush()?;
    Ok(())
}

/// Every node's canonical chain size at every sealing (any node's).
fn write_chain_bytes(index: &inspect::RunIndex, mut w: Csv) -> anyhow::Result<()> {
    w.write_record(["time_s", "node", "chain_bytes"])?;
    for row in &index.chain_bytes {
        for (node, bytes) in row.bytes.iter().enumerate() {
            w.write_record([
                row.time.secs().to_string(),
                node.to_string(),
                bytes.to_string(),
            ])?;
        }
    }
    w.flush()?;
    Ok(())
}

/// The samples of every robot's data set at the end of the run (expired ones are gone);
/// returns the number of samples.
fn write_trajectories(index: &inspect::RunIndex, mut w: Csv) -> anyhow::Result<usize> {
    w.write_record(["robot", "sample", "completed_s", "point", "x", "y"])?;
    let world = &index.final_state.world;
    let mut samples = 0usize;
    for robot in 0..index.config.world.robots {
        for (i, sample) in world.dataset(robot).iter().enumerate() {
            samples += 1;
            for (p, [x, y]) in sample.points.iter().enumerate() {
                w.write_record([
                    robot.to_string(),
                    i.to_string(),
                    sample.time.secs().to_string(),
                    p.to_string(),
                    x.to_string(),
                    y.to_string(),
                ])?;
            }
        }
    }
    w.flush()?;
    Ok(samples)
}

//! A run's CSV tables (`swarmfl export`): CSV tables of a run, from one fold of its log. The tables are built by
//! the core (`inspect::Table`), the same the Python package loads as data frames.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use swarmfl_core::config::Aggregation;
use swarmfl_core::inspect::{self, Table};

use crate::progress::{warn_if_truncated, Watch};

/// Writes `rounds.csv`, `submissions.csv`, `balances.csv`, `chain_bytes.csv` and
/// `trajectories.csv` into `out` (a baseline run, which has no blocks or tokens: `rounds.csv`,
/// its aggregations, and `trajectories.csv`); returns the line that says what it wrote. A
/// truncated log is warned of on `watch`.
pub fn export(log: &Path, out: &Path, watch: &dyn Watch) -> anyhow::Result<String> {
    let start = Instant::now();
    let index = inspect::index_run(log, None)?;
    warn_if_truncated(watch, &index);
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let rounds = index.rounds_table()?;
    write(out, "rounds.csv", &rounds)?;
    let trajectories = index.trajectories_table();
    write(out, "trajectories.csv", &trajectories)?;
    let samples: usize = (0..index.config.world.robots)
        .map(|r| index.final_state.world.dataset(r).len())
        .sum();
    let kind = index.config.learn.aggregation;
    let line = if kind == Aggregation::Chain {
        let submissions = index.submissions_table()?;
        write(out, "submissions.csv", &submissions)?;
        write(out, "balances.csv", &index.balances_table()?)?;
        write(out, "chain_bytes.csv", &index.chain_bytes_table()?)?;
        format!(
            "wrote {}: rounds.csv ({} rounds), submissions.csv ({} submissions), balances.csv (genesis and the {} blocks of the final canonical chain x {} robots), chain_bytes.csv (every node's chain at each of the {} sealings on all forks), trajectories.csv ({} samples of the final data sets) in {:.0} ms",
            out.display(),
            rounds.rows(),
            submissions.rows(),
            index.last_height(),
            index.config.world.robots,
            index.chain_bytes.len(),
            samples,
            start.elapsed().as_secs_f64() * 1000.0
        )
    } else {
        format!(
            "wrote {}: rounds.csv ({} aggregations of the {} run), trajectories.csv ({} samples of the final data sets) in {:.0} ms; a {} run has no blocks or tokens, so no submissions, balances or chain_bytes tables",
            out.display(),
            rounds.rows(),
            kind.name(),
            samples,
            start.elapsed().as_secs_f64() * 1000.0,
            kind.name()
        )
    };
    Ok(line)
}

/// Writes `table` as `out/name`, a header row then one row per record.
fn write(out: &Path, name: &str, table: &Table) -> anyhow::Result<()> {
    let path = out.join(name);
    let mut w = csv::Writer::from_path(&path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    w.write_record(table.names())?;
    let mut row = Vec::with_capacity(table.columns.len());
    for i in 0..table.rows() {
        row.clear();
        row.extend(table.columns.iter().map(|(_, c)| c.cell(i)));
        w.write_record(&row)?;
    }
    w.flush()
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

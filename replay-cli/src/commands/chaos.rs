//! `swarmfl chaos`: a seeded fault campaign (see `swarmfl_core::chaos` for what each seed draws
//! and the invariants checked at every block). A violation prints its seed and the one command
//! that replays it; the exit code is then 1.
//!
//! Each seed reports on stderr as soon as it finishes (a text line, or with `--json` one JSON
//! object per line), so a campaign cut short still says what it found; the summary goes to
//! stdout at the end. `--configs DIR` writes each seed's drawn configuration, so that
//! `swarmfl run --config DIR/seed-N.toml --seed N` writes the log of that very run for
//! `inspect`, `bisect` and `view`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;
use swarmfl_core::chaos::{self, Outcome, Violation};

use crate::cli::ChaosArgs;

/// One seed's result as the progress line of `--json` on stderr.
#[derive(Serialize)]
struct SeedLine<'a> {
    seed: u64,
    #[serde(flatten)]
    outcome: &'a Outcome,
}

#[derive(Serialize)]
struct SeedViolation {
    seed: u64,
    command: String,
    #[serde(flatten)]
    violation: Violation,
}

#[derive(Serialize)]
struct Report {
    runs: u64,
    duration_s: f64,
    first_seed: u64,
    violations: Vec<SeedViolation>,
    wall_s: f64,
    blocks_checked: u64,
    liveness_checked: u64,
    /// Runs whose open round's quorum was, after the last heal, out of reach under a contract
    /// without a deadline, for want of stakes or of data
    /// (`swarmfl_core::chaos::quorum_out_of_reach`): liveness was owed only while it was
    /// within reach.
    liveness_stalled: u64,
    max_deepest_reorg: u64,
    equivocations_detected: u64,
    /// Sealers removed from the signer set for equivocating, summed over runs (each run's
    /// heaviest honest chain at the end).
    removed_sealers: u64,
    bounds: Bounds,
}

#[derive(Serialize)]
struct Bounds {
    prefix_bound_blocks: u64,
    settle_s: u64,
    liveness_s: u64,
    /// The liveness window with a deadline is at least the deadline plus this.
    deadline_slack_s: u64,
    punish_s: u64,
}

/// The command that replays seed `seed` alone.
fn replay_command(seed: u64, duration_s: f64) -> String {
    format!("swarmfl chaos --seeds 1 --first-seed {seed} --duration {duration_s}")
}

/// The last seed of the campaign `first..first + seeds`, refusing a range that runs past
/// `u64::MAX` (it would wrap to an empty range and pass with nothing checked).
fn last_seed(seeds: u64, first: u64) -> anyhow::Result<u64> {
    let span = seeds - 1;
    first.checked_add(span).ok_or_else(|| {
        anyhow::anyhow!(
            "--first-seed {first} with --seeds {seeds} runs past the largest seed {}: \
             with --seeds {seeds} the largest allowed --first-seed is {}",
            u64::MAX,
            u64::MAX - span
        )
    })
}

/// Runs `swarmfl chaos`.
pub fn command(args: ChaosArgs) -> anyhow::Result<ExitCode> {
    run(
        args.seeds,
        args.first_seed,
        args.duration,
        args.json,
        args.configs.as_deref(),
    )
}

/// The file `--configs DIR` writes seed `seed`'s configuration to.
fn config_path(dir: &Path, seed: u64) -> PathBuf {
    dir.join(format!("seed-{seed}.toml"))
}

/// Prints one finished seed on stderr at once (a line per seed, whole lines only, so lines
/// of seeds finishing together never interleave).
fn progress(seed: u64, outcome: &anyhow::Result<Outcome>, json: bool) {
    let line = match (outcome, json) {
        (Ok(o), true) => serde_json::to_string(&SeedLine { seed, outcome: o })
            .unwrap_or_else(|e| format!("{{\"seed\":{seed},\"error\":\"{e}\"}}")),
        (Err(e), true) => {
            serde_json::json!({ "seed": seed, "error": format!("{e:#}") }).to_string()
        }
        (Ok(o), false) => match &o.violation {
            None => format!(
                "seed {seed}: ok ({} blocks checked, height {}, deepest reorg {}, \
                 {} equivocations, {} sealers removed, {} rounds{})",
                o.blocks_checked,
                o.height,
                o.deepest_reorg,
                o.equivocations,
                o.removed_sealers,
                o.rounds,
                if o.liveness_stalled {
                    ", stalled: quorum out of reach"
                } else {
                    ""
                }
            ),
            Some(v) => format!(
                "seed {seed}: VIOLATION {} at {} ms: {}",
                v.invariant, v.at_ms, v.detail
            ),
        },
        (Err(e), false) => format!("seed {seed}: error {e:#}"),
    };
    let mut err = std::io::stderr().lock();
    // A closed stderr must not stop the campaign: the summary still goes to stdout.
    let _ = writeln!(err, "{line}");
}

/// Runs seeds `first..first + seeds` with runs of `duration_s`.
fn run(
    seeds: u64,
    first: u64,
    duration_s: f64,
    json: bool,
    configs: Option<&Path>,
) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(seeds > 0, "--seeds must be at least 1");
    anyhow::ensure!(
        duration_s.is_finite() && duration_s >= 1.0,
        "--duration must be at least 1 (seconds), got {duration_s}"
    );
    let last = last_seed(seeds, first)?;
    if let Some(dir) = configs {
        std::fs::create_dir_all(dir).map_err(|e| {
            anyhow::anyhow!(
                "--configs {}: cannot create the directory: {e}",
                dir.display()
            )
        })?;
    }
    let start = Instant::now();
    let results: Vec<(u64, anyhow::Result<Outcome>)> = (first..=last)
        .into_par_iter()
        .map(|seed| {
            let outcome = run_seed(seed, duration_s, configs);
            progress(seed, &outcome, json);
            (seed, outcome)
        })
        .collect();
    anyhow::ensure!(
        results.len() as u64 == seeds,
        "ran {} seeds instead of {seeds}",
        results.len()
    );
    let mut report = Report::new(results.len() as u64, duration_s, first);
    for (seed, outcome) in results {
        report.add(seed, outcome)?;
    }
    report.wall_s = start.elapsed().as_secs_f64();
    report.print(json)?;
    Ok(if report.violations.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// Draws seed `seed`'s configuration (written into `configs` if given) and checks its run.
fn run_seed(seed: u64, duration_s: f64, configs: Option<&Path>) -> anyhow::Result<Outcome> {
    let config = chaos::draw(seed, duration_s);
    match configs {
        Some(dir) => {
            let path = config_path(dir, seed);
            std::fs::write(&path, config.to_toml())
                .map_err(|e| anyhow::anyhow!("--configs: cannot write {}: {e}", path.display()))
        }
        None => Ok(()),
    }
    .and_then(|()| chaos::check(config, seed).map_err(anyhow::Error::from))
}

impl Report {
    /// The report of `runs` runs of `duration_s` from `first_seed`, before any is added.
    fn new(runs: u64, duration_s: f64, first_seed: u64) -> Report {
        Report {
            runs,
            duration_s,
            first_seed,
            violations: Vec::new(),
            wall_s: 0.0,
            blocks_checked: 0,
            liveness_checked: 0,
            liveness_stalled: 0,
            max_deepest_reorg: 0,
            equivocations_detected: 0,
            removed_sealers: 0,
            bounds: Bounds {
                prefix_bound_blocks: chaos::PREFIX_BOUND_BLOCKS,
                settle_s: chaos::SETTLE_MS / 1000,
                liveness_s: chaos::LIVENESS_MS / 1000,
                deadline_slack_s: chaos::DEADLINE_SLACK_MS / 1000,
                punish_s: chaos::PUNISH_MS / 1000,
            },
        }
    }

    /// Adds seed `seed`'s outcome; an error, or a run that checked no block, is the campaign's
    /// error.
    fn add(&mut self, seed: u64, outcome: anyhow::Result<Outcome>) -> anyhow::Result<()> {
        let outcome = outcome.map_err(|e| e.context(format!("seed {seed}")))?;
        // Every run checks at least its genesis block, so a run that checked none did not check
        // anything and must not count as a pass.
        anyhow::ensure!(
            outcome.blocks_checked > 0,
            "seed {seed}: no block was checked, so the run proves nothing"
        );
        self.blocks_checked += outcome.blocks_checked;
        self.liveness_checked += u64::from(outcome.liveness_checked);
        self.liveness_stalled += u64::from(outcome.liveness_stalled);
        self.max_deepest_reorg = self.max_deepest_reorg.max(outcome.deepest_reorg);
        self.equivocations_detected += outcome.equivocations;
        self.removed_sealers += outcome.removed_sealers;
        if let Some(violation) = outcome.violation {
            self.violations.push(SeedViolation {
                seed,
                command: replay_command(seed, self.duration_s),
                violation,
            });
        }
        Ok(())
    }

    /// Prints the report on stdout: JSON with `json`, else a summary line and each violation
    /// with the command that replays it.
    fn print(&self, json: bool) -> anyhow::Result<()> {
        let duration_s = self.duration_s;
        if json {
            println!("{}", serde_json::to_string_pretty(self)?);
        } else {
            println!(
                "{} runs of {duration_s} s, {} blocks checked, {} equivocations detected, \
                 {} sealers removed, {} stalled (quorum out of reach: stakes or data), \
                 {} violations, {:.1} s wall",
                self.runs,
                self.blocks_checked,
                self.equivocations_detected,
                self.removed_sealers,
                self.liveness_stalled,
                self.violations.len(),
                self.wall_s
            );
            for v in &self.violations {
                println!(
                    "seed {}: {} at {} ms: {}\n  replay: {}",
                    v.seed, v.violation.invariant, v.violation.at_ms, v.violation.detail, v.command
                );
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::last_seed;

    #[test]
    fn the_seed_range_ends_at_u64_max_and_never_wraps() {
        assert_eq!(last_seed(1, u64::MAX).unwrap(), u64::MAX);
        assert_eq!(last_seed(2, u64::MAX - 1).unwrap(), u64::MAX);
        assert_eq!(last_seed(10, 5).unwrap(), 14);
        let e = last_seed(2, u64::MAX).unwrap_err().to_string();
        assert!(
            e.contains("--first-seed 18446744073709551615 with --seeds 2")
                && e.contains("largest allowed --first-seed is 18446744073709551614"),
            "{e}"
        );
    }
}

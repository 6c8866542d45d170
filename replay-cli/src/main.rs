//! The `swarmfl` command: run, replay and inspect swarmfl simulations.

mod bench_scale;
mod bench_train;
mod bench_world;
mod chaos;
mod experiments;
mod export;
mod fixtures;
mod fork;
mod inspect;
mod png;
mod progress;
mod report;
mod results;
mod run;
mod snapshot;
mod sweep;
mod view;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};
use swarmfl_core::config::{Config, Preset};
use swarmfl_core::log::LogError;
use swarmfl_core::replay::{self, ReplayError};
use swarmfl_core::SimTime;

/// swarmfl: a deterministic, event-sourced replay engine for blockchain-secured federated
/// learning in robot swarms.
#[derive(Parser, Debug)]
#[command(name = "swarmfl", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Which configuration to use: a preset, a TOML file over it, and overrides.
#[derive(Args, Debug, Clone)]
struct ConfigArgs {
    /// The preset to start from (see `swarmfl presets`); default `paper`.
    #[arg(long)]
    preset: Option<String>,
    /// A TOML file overlaid on the preset (it may name its own `preset`).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Overrides, `key.path=value`, applied in order (e.g. `--set world.robots=30`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    overrides: Vec<String>,
}

impl ConfigArgs {
    fn resolve(&self) -> anyhow::Result<Config> {
        Ok(Config::resolve(
            self.preset.as_deref(),
            self.config.as_deref(),
            &self.overrides,
        )?)
    }
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate a run: writes DIR/run.swlog and DIR/summary.json.
    Run {
        #[command(flatten)]
        config: ConfigArgs,
        /// The seed: with the configuration, it determines the whole run.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output directory (default `runs/<preset>-seed<N>`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// No progress bar and no summary on stdout.
        #[arg(long)]
        quiet: bool,
    },
    /// Replay a log: fold its events and check every checkpoint (or re-simulate it).
    Replay {
        /// The log (run.swlog).
        log: PathBuf,
        /// Re-simulate from the header's seed and configuration and compare every record.
        #[arg(long)]
        resimulate: bool,
    },
    /// Draw the arena, obstacles, robots (Byzantine ones marked) and radio links at a simulated
    /// time or right after a block of the final canonical chain (SVG or PNG).
    Snapshot {
        /// The log (run.swlog).
        log: PathBuf,
        /// Simulated time in seconds (the state after the last tick at or before it).
        #[arg(long, conflicts_with = "block", required_unless_present = "block")]
        time: Option<f64>,
        /// Height on the final canonical chain (the state right after its sealing).
        #[arg(long)]
        block: Option<u64>,
        /// Output file: `.svg` or `.png`.
        #[arg(long)]
        out: PathBuf,
    },
    /// Write one self-contained HTML file to watch a run in a browser (no network, no server):
    /// the arena with robots, ids, Byzantine marks and radio links, animated with a scrubber
    /// that also jumps by block height; each robot's tokens, the loss per round and the chain
    /// with its forks and reorgs up to the time shown. `run.html#t=600` or `#block=40` opens
    /// at that moment.
    View {
        /// The log (run.swlog).
        log: PathBuf,
        /// Output file (e.g. run.html).
        #[arg(long)]
        out: PathBuf,
    },
    /// Compare two logs: header differences and the first diverging record (exit 1 if they
    /// differ). With --resimulate, compare one log with a re-simulation under this build: exit
    /// 0 identical, 1 diverged, 125 when the log cannot be read (`git bisect run` skips).
    Diff {
        /// The first log.
        a: PathBuf,
        /// The second log (omit with --resimulate).
        b: Option<PathBuf>,
        /// Compare `a` with a fresh re-simulation of its header's seed and configuration.
        #[arg(long)]
        resimulate: bool,
    },
    /// Regression fixtures: `regenerate` re-makes fixtures/logs and fixtures/expected.toml
    /// from fixtures/manifest.toml (after an intentional change; see CHANGELOG.md).
    Fixtures {
        /// What to do.
        action: FixturesAction,
        /// The fixtures folder.
        #[arg(long, default_value = "fixtures")]
        dir: PathBuf,
    },
    /// Show block H of the final canonical chain: the block, the contract state after it, every
    /// node's head and the world at that moment (and the time it took).
    Inspect {
        /// The log (run.swlog).
        log: PathBuf,
        /// Height on the final canonical chain (the best node's chain at the end; 0 = genesis).
        #[arg(long, required_unless_present = "time", conflicts_with = "time")]
        block: Option<u64>,
        /// A baseline run (`learn.aggregation` gossip or central, no blocks): the state at the
        /// last checkpoint at or before this simulated time, s.
        #[arg(long)]
        time: Option<f64>,
        /// Narrow to one robot's view too (its node, balance, data, last learning phase).
        #[arg(long)]
        robot: Option<u32>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Ignore (and do not write) the sidecar index LOG.idx: fold the whole log.
        #[arg(long)]
        no_index: bool,
    },
    /// Find the first block of the final canonical chain where a predicate holds (exit 1 if none);
    /// in a baseline run (no blocks), the first checkpoint by time (time, round, loss,
    /// heldout_loss).
    #[command(after_long_help = BISECT_HELP)]
    Bisect {
        /// The log (run.swlog).
        log: PathBuf,
        /// The predicate, e.g. "byzantine_tokens > honest_tokens" (see --help for the grammar).
        #[arg(long)]
        until: String,
        /// Declare the predicate monotone (false, then true for good): binary search with
        /// O(log n) evaluations instead of a scan.
        #[arg(long)]
        monotone: bool,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Continue a run from block H of its final canonical chain under a changed configuration.
    /// The fork's log records its parent's final hash, the height and the overrides, holds the
    /// parent's records up to the fork point (re-simulated and checked byte for byte against
    /// the parent) and replays on its own.
    #[command(after_long_help = FORK_HELP)]
    Fork {
        /// The parent log (run.swlog).
        log: PathBuf,
        /// Height on the parent's final canonical chain (at least 1).
        #[arg(long)]
        at: u64,
        /// Override a key from the fork point on (repeatable), e.g. --set contract.security=true.
        #[arg(long = "set", value_name = "KEY=VALUE", required = true)]
        overrides: Vec<String>,
        /// Output directory (default: next to the parent, fork-at-H).
        #[arg(long)]
        out: Option<PathBuf>,
        /// No progress bar and no summary.
        #[arg(long)]
        quiet: bool,
    },
    /// Write CSV tables of a run: rounds.csv (per closed round: time, loss, held-out loss,
    /// accepted, outliers), balances.csv (every robot's balance after every block of the final
    /// canonical chain), chain_bytes.csv (every node's chain size at every sealing) and
    /// trajectories.csv (the samples of every robot's data set at the end of the run).
    Export {
        /// The log (run.swlog).
        log: PathBuf,
        /// Output directory (created).
        #[arg(long)]
        out: PathBuf,
    },
    /// Run one of the paper's experiments (or a shard of it): every configuration point x seed.
    #[command(long_about = SWEEP_HELP)]
    Sweep {
        /// The experiment: e0-baselines, e1-expiration, e1-faulty, e2-faulty, e2-malicious,
        /// e3-smart, e4-robustness or e5-smart-defence.
        experiment: String,
        /// Results directory: one DIR/<experiment>/<point>/seed<N>.json per task.
        #[arg(long)]
        out: PathBuf,
        /// Runs (seeds 1..=N) per point; default the paper's (5, 10, 20, 20, 18).
        #[arg(long)]
        runs: Option<u32>,
        /// Runs in parallel; default the number of cores.
        #[arg(long)]
        jobs: Option<usize>,
        /// Run only shard I of N: the tasks whose index modulo N is I.
        #[arg(long, value_name = "I/N")]
        shard: Option<String>,
        /// The shard count when the index comes from JOB_COMPLETION_INDEX (or SWARMFL_SHARDS).
        #[arg(long)]
        shards: Option<u32>,
        /// Overrides for every task, `key.path=value` (e.g. `--set run.duration_s=600`).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        overrides: Vec<String>,
        /// Keep each run's log in DIR/<experiment>/<point>/seed<N>/ (default: deleted).
        #[arg(long)]
        keep_logs: bool,
    },
    /// Merge a sweep's results: means and 95 % CIs, the paper's figures (SVG, PNG), report.md.
    Report {
        /// The results directory of one or more sweeps (shards merged by copying into it).
        dir: PathBuf,
        /// Report directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// A seeded fault campaign: each seed draws a configuration, Byzantine behaviours and a
    /// fault schedule, runs it and checks invariants at every block (conservation, validity,
    /// agreement after heals, liveness). Exits 1 on a violation, naming the seed and the
    /// command that replays it.
    Chaos {
        /// How many seeds.
        #[arg(long, default_value_t = 10)]
        seeds: u64,
        /// The first seed.
        #[arg(long, default_value_t = 0)]
        first_seed: u64,
        /// Simulated seconds per run.
        #[arg(long, default_value_t = 600.0)]
        duration: f64,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// List the presets.
    Presets,
    /// Print the fully resolved configuration as TOML.
    Config {
        #[command(flatten)]
        config: ConfigArgs,
    },
    /// Time one subsystem and print its figures.
    Bench {
        /// Which subsystem.
        target: BenchTarget,
        /// Print machine-readable JSON.
        #[arg(long)]
        json: bool,
        /// `scale` only: the swarm sizes, comma-separated.
        #[arg(long, value_name = "N,N,..")]
        robots: Option<String>,
        /// `scale` only: simulated seconds per size (default 300; the 960-robot size then takes
        /// about 1.5 min on a 2-core machine, the others under 20 s each).
        #[arg(long)]
        duration_s: Option<f64>,
    },
    /// One size of `bench scale`, run in a child process so that its peak RSS is its own:
    /// prints one JSON line.
    #[command(hide = true)]
    BenchScaleOne {
        /// Robots.
        #[arg(long)]
        robots: u32,
        /// Simulated seconds.
        #[arg(long)]
        duration_s: f64,
    },
}

const BISECT_HELP: &str = "\
The predicate language (values are f64; comparisons and logic give 1 or 0; anything compared
with NaN is false; a value is true when non-zero and not NaN):
  expr    := or
  or      := and ( \"||\" and )*
  and     := cmp ( \"&&\" cmp )*
  cmp     := sum ( ( < | <= | > | >= | == | != ) sum )?      (comparisons do not chain)
  sum     := product ( ( + | - ) product )*
  product := unary ( ( * | / ) unary )*
  unary   := ( ! | - ) unary | primary
  primary := NUMBER | IDENT | balance[INT] | node[INT].height | ( expr )
Identifiers, at each block of the final canonical chain:
  height            the block's height
  time              its timestamp, simulated s
  round             rounds closed up to the block: the number of the last closed round
                    (rounds count from 1 everywhere: the run summary's r1, rounds.csv,
                    inspect), also the shared model's version
  loss              paper metric of the last round closed up to the block (NaN before)
  heldout_loss      loss of the block's shared model on the held-out set
  byzantine_tokens  MEAN balance of the Byzantine robots, tokens (NaN without any)
  honest_tokens     MEAN balance of the honest robots, tokens (NaN without any)
  byzantine_wealth  byzantine_tokens plus the group's stakes in the current round, per robot
  honest_wealth     honest_tokens plus the group's stakes in the current round, per robot
  byzantine_sum     total balance of the Byzantine robots, tokens
  honest_sum        total balance of the honest robots, tokens
  accepted          accepted submissions in the current round
  outliers          outlier submissions in the current round
  pool              tokens held by the contract (stakes and carried remainders)
  robots            number of robots
  balance[i]        robot i's balance after the block, tokens
  node[i].height    height of node i's head right after the block was sealed
Examples: \"byzantine_tokens > honest_tokens\", \"loss > 0.1\", \"round >= 50\",
\"node[3].height + 5 < node[0].height\".
Both modes first fold the whole log once (checking every checkpoint, ~0.6 s for a paper run) to
learn the final canonical chain; the search then evaluates the per-block values in memory.";

#[derive(Clone, Copy, Debug, ValueEnum)]
enum FixturesAction {
    /// Re-run every fixture of the manifest and rewrite the expected hashes.
    Regenerate,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum BenchTarget {
    /// Physics + sensing + data.
    World,
    /// One local training of the reference workload.
    Train,
    /// Whole `paper` runs at the paper's density at growing swarm sizes (default 15, 60, 240,
    /// 960 robots, 300 simulated s each): wall, CPU and per-part time per robot-simulated-second,
    /// peak RSS per size.
    Scale,
}

/// The long help of `swarmfl sweep`: the task list and sharding.
const FORK_HELP: &str =
    "The fork point of block H is the end of the tick in which H was sealed: from there
the robots use the new configuration, and the contract's new rules apply to the blocks sealed
after it (activation by block timestamp; the round open on a chain when it crosses is restarted
and its stakes refunded). Keys a fork may change:

  run.duration_s                     the run ends at the new time
  learn.* (not lstm_units)           the next trainings' hyper-parameters and schedule
  contract.security, stake_tokens, quorum_fraction, outlier_threshold, penalised_ranks,
  reward_weights, median, fedavg_rounding, int48_products, threshold, rank_key, rank_ties,
  payout_rounding, pool
  byzantine.*                        which robots misbehave, and how
  output.*

Example: what if security had been on from block 200?
  swarmfl run --preset e2-faulty --set contract.security=false --seed 1 --out runs/nosec
  swarmfl fork runs/nosec/run.swlog --at 200 --set contract.security=true --out runs/sec-at-200
  swarmfl replay runs/sec-at-200/run.swlog            # bit-exact on its own
  swarmfl diff runs/nosec/run.swlog runs/sec-at-200/run.swlog   # first divergence: the fork";

const SWEEP_HELP: &str =
    "Run one of the paper's experiments (docs/SPEC.md section 7), or a shard of it.

Experiments, points and default runs (seeds 1..=runs):
  e0-baselines   {chain,gossip,central}-{clean,faulty-1,malicious-3} (learn.aggregation) 5 runs
  e1-expiration  expiration-250..1250 (data.expiration_s = 250, 500, 750, 1000, 1250)  5 runs
  e1-faulty      faulty-1 (security off, 1 faulty robot, expiration 750 s)            10 runs
  e2-faulty      byzantine-0..7 (byzantine.count; kind none for 0)                    20 runs
  e2-malicious   byzantine-0..7                                                        20 runs
  e3-smart       byzantine-0..7                                                        18 runs
  e4-robustness  <rule>--<attack>--<count>: 9 rules x (clean + 12 attacks x {3, 7})       3 runs
  e5-smart-defence  <defence>--<attack>--<count>: defences none, agreement, innovation x
                 (smart 0..7, smart-then-collude 3, 5, 7, faulty 3, malicious 3)       3 runs

Task list (fixed): point-major, task index = point_index * runs + (seed - 1), points in the
order above. Shard I/N runs the tasks with index % N == I. The shard comes from --shard I/N,
else SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN (MIN 0 if unset) of SLURM_ARRAY_TASK_COUNT
(or --shards N), else JOB_COMPLETION_INDEX of --shards N or SWARMFL_SHARDS; else all tasks.

Each task writes DIR/<experiment>/<point>/seed<N>.json (the run's summary plus a `sweep`
section) atomically; existing, parseable result files are skipped, so re-running the same
command resumes a sweep and retries failed tasks.";

/// Exit code for a run that is not bit-exact (divergence or damaged log).
const EXIT_DIVERGED: u8 = 1;
/// Exit code for bad arguments or input.
const EXIT_ERROR: u8 = 2;
/// Exit code of `diff --resimulate` when the log cannot be read: `git bisect run`'s "skip".
const EXIT_CANNOT_TEST: u8 = 125;

fn main() -> ExitCode {
    // Output piped into `head` and the like ends quietly, as other command-line tools do,
    // instead of panicking on the broken pipe.
    // SAFETY: called once at start-up, before any other thread exists; SIG_DFL is a valid
    // disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    match dispatch(cli.command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            // Exit 1 when a log is damaged or a run is not bit-exact; 2 for bad arguments,
            // missing files and foreign files.
            let diverged = matches!(
                e.downcast_ref::<ReplayError>(),
                Some(ReplayError::Diverged { .. } | ReplayError::Apply { .. })
                    | Some(ReplayError::Log(
                        LogError::Corrupt { .. } | LogError::Truncated { .. }
                    ))
            );
            ExitCode::from(if diverged { EXIT_DIVERGED } else { EXIT_ERROR })
        }
    }
}

fn dispatch(command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Run {
            config,
            seed,
            out,
            quiet,
        } => {
            let config = config.resolve()?;
            let out =
                out.unwrap_or_else(|| PathBuf::from(format!("runs/{}-seed{seed}", config.preset)));
            let outcome = run::run(config, seed, &out, quiet)?;
            if !quiet {
                run::print_summary(&outcome);
                run::print_next(&outcome);
            }
        }
        Command::Replay { log, resimulate } => {
            let report = if resimulate {
                replay::resimulate(&log)?
            } else {
                replay::replay(&log)?
            };
            println!(
                "bit-exact: {} records, {} blocks ({} checkpoints verified{}); final hash {}",
                report.records,
                report.blocks,
                report.checkpoints,
                if resimulate {
                    ", every record re-simulated"
                } else {
                    ""
                },
                report.final_hash
            );
        }
        Command::Snapshot {
            log,
            time,
            block,
            out,
        } => snapshot_command(&log, time, block, &out)?,
        Command::View { log, out } => {
            let v = view::view(&log, &out)?;
            println!(
                "wrote {} ({:.1} MB: {} frames, one every {} s plus one per block of the final \
                 chain; {} blocks of every node); open it in a browser",
                out.display(),
                v.bytes as f64 / 1.0e6,
                v.frames,
                v.frame_s,
                v.blocks
            );
        }
        Command::Diff { a, b, resimulate } => {
            return diff(&a, b.as_deref(), resimulate).map(ExitCode::from)
        }
        Command::Fixtures {
            action: FixturesAction::Regenerate,
            dir,
        } => fixtures::regenerate(&dir)?,
        Command::Inspect {
            log,
            block,
            time,
            robot,
            json,
            no_index,
        } => match (block, time) {
            (Some(block), _) => inspect::inspect(&log, block, robot, json, !no_index)?,
            (None, Some(time)) => inspect::inspect_time(&log, time, json)?,
            (None, None) => anyhow::bail!("give --block HEIGHT or --time SECONDS"),
        },
        Command::Bisect {
            log,
            until,
            monotone,
            json,
        } => {
            if !inspect::bisect(&log, &until, monotone, json)? {
                return Ok(ExitCode::from(EXIT_DIVERGED));
            }
        }
        Command::Fork {
            log,
            at,
            overrides,
            out,
            quiet,
        } => fork::fork(&log, at, &overrides, out, quiet)?,
        Command::Export { log, out } => export::export(&log, &out)?,
        Command::Sweep {
            experiment,
            out,
            runs,
            jobs,
            shard,
            shards,
            overrides,
            keep_logs,
        } => {
            let shard = sweep::Shard::resolve(shard.as_deref(), shards, |k| std::env::var(k).ok())?;
            let outcome = sweep::sweep(&sweep::SweepOptions {
                experiment,
                out,
                runs,
                jobs,
                shard,
                overrides,
                keep_logs,
            })?;
            println!(
                "sweep: {} tasks in shard, {} ran, {} already done, {} failed, {:.1} s",
                outcome.selected,
                outcome.ran,
                outcome.skipped,
                outcome.failed.len(),
                outcome.wall_s
            );
            if !outcome.failed.is_empty() {
                for (task, error) in &outcome.failed {
                    eprintln!(
                        "task {} ({} seed {}): {error}",
                        task.index, task.point, task.seed
                    );
                }
                anyhow::bail!(
                    "{} tasks failed; re-run the same command to retry them",
                    outcome.failed.len()
                );
            }
        }
        Command::Report { dir, out } => {
            let path = report::report(&dir, &out)?;
            println!("wrote {}", path.display());
        }
        Command::Chaos {
            seeds,
            first_seed,
            duration,
            json,
        } => return chaos::run(seeds, first_seed, duration, json),
        Command::Presets => {
            for preset in Preset::ALL {
                println!("{:<14} {}", preset.name(), preset.description());
            }
        }
        Command::Config { config } => {
            let config = config.resolve()?;
            print!("{}", config.to_toml());
        }
        Command::Bench {
            target,
            json,
            robots,
            duration_s,
        } => match target {
            BenchTarget::Scale => bench_scale::run(
                &bench_scale::parse_robots(
                    robots.as_deref().unwrap_or(bench_scale::DEFAULT_ROBOTS),
                )?,
                duration_s.unwrap_or(bench_scale::DEFAULT_DURATION_S),
                json,
            )?,
            _ if robots.is_some() || duration_s.is_some() => {
                anyhow::bail!("--robots and --duration-s belong to `bench scale` only")
            }
            BenchTarget::World => bench_world::run(json)?,
            BenchTarget::Train => bench_train::run(json)?,
        },
        Command::BenchScaleOne { robots, duration_s } => bench_scale::one(robots, duration_s)?,
    }
    Ok(ExitCode::SUCCESS)
}

fn diff(a: &std::path::Path, b: Option<&std::path::Path>, resimulate: bool) -> anyhow::Result<u8> {
    match (b, resimulate) {
        (None, true) => match replay::resimulate(a) {
            Ok(report) => {
                println!(
                    "identical: {} records re-simulated bit-exactly; final hash {}",
                    report.records, report.final_hash
                );
                Ok(0)
            }
            Err(ReplayError::Diverged {
                index,
                kind,
                time,
                component,
                detail,
                ..
            }) => {
                println!("first divergence from the re-simulation: record {index} ({kind} at t = {time}): {component} differs{detail}");
                Ok(EXIT_DIVERGED)
            }
            Err(e @ ReplayError::Apply { .. }) => {
                println!("first divergence from the re-simulation: {e}");
                Ok(EXIT_DIVERGED)
            }
            Err(e) => {
                // The log cannot be read (damaged, foreign, or a header this build does not
                // accept): nothing was compared, so this is not a divergence. 125 is
                // `git bisect run`'s "cannot test this commit, skip it".
                eprintln!("error: {e}");
                eprintln!(
                    "(exit {EXIT_CANNOT_TEST}: the log could not be compared; `git bisect run` \
                     skips this commit)"
                );
                Ok(EXIT_CANNOT_TEST)
            }
        },
        (Some(b), false) => {
            let report = swarmfl_core::diff::diff_logs(a, b)?;
            if report.header_differences.is_empty() {
                println!("headers: same seed and configuration");
            } else {
                println!("headers differ:");
                for d in &report.header_differences {
                    println!("  {d}");
                }
            }
            match &report.divergence {
                None => {
                    println!(
                        "identical: {} records; final hashes {} / {}",
                        report.identical_records,
                        report.final_hashes.0.short(),
                        report.final_hashes.1.short()
                    );
                    Ok(if report.final_hashes.0 == report.final_hashes.1 {
                        0
                    } else {
                        EXIT_DIVERGED
                    })
                }
                Some(d) => {
                    println!(
                        "{} identical records, then the first divergence:",
                        report.identical_records
                    );
                    println!(
                        "  record {} at t = {} (byte offsets {} / {}), kinds {} / {}",
                        d.index, d.time, d.offsets.0, d.offsets.1, d.kinds.0, d.kinds.1
                    );
                    println!("  {}", d.explanation);
                    Ok(EXIT_DIVERGED)
                }
            }
        }
        (None, false) => anyhow::bail!("diff needs two logs, or one log and --resimulate"),
        (Some(_), true) => {
            anyhow::bail!("--resimulate compares one log with a re-simulation; give only one log")
        }
    }
}

fn snapshot_command(
    log: &std::path::Path,
    time: Option<f64>,
    block: Option<u64>,
    out: &std::path::Path,
) -> anyhow::Result<()> {
    let (world, config, seed, title) = match (time, block) {
        (_, Some(height)) => {
            let index = swarmfl_core::inspect::index_run(log, Some(height))?;
            inspect::warn_if_truncated(&index);
            let (state, _) = index
                .at_block
                .ok_or_else(|| anyhow::anyhow!("block {height} was not captured"))?;
            let title = format!(
                "{} after block {height} (t = {})",
                log.display(),
                state.world.time()
            );
            (state.world, index.config, index.seed, title)
        }
        (Some(time), None) => {
            if !(time.is_finite() && time >= 0.0) {
                anyhow::bail!("--time must be a non-negative number of seconds, got {time}");
            }
            let (state, config, seed) = replay::state_at_time(log, SimTime::from_secs(time))?;
            let title = format!("{} at t = {}", log.display(), state.world.time());
            (state.world, config, seed, title)
        }
        (None, None) => anyhow::bail!("give --time SECONDS or --block HEIGHT"),
    };
    let marks: Vec<snapshot::RobotMark> = swarmfl_core::byzantine::byzantine_robots(&config, seed)
        .into_iter()
        .map(|b| {
            if b {
                snapshot::RobotMark::Byzantine
            } else {
                snapshot::RobotMark::Honest
            }
        })
        .collect();
    snapshot::draw(&world, &marks, &title, out)?;
    println!("wrote {} ({title})", out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diff_resimulate_exits_125_on_a_log_it_cannot_read_and_1_on_divergence() {
        let dir = std::env::temp_dir().join(format!("swarmfl-diff-exit-{}", std::process::id()));
        let config = Config::resolve(
            Some("smoke"),
            None,
            &["run.duration_s=30".into(), "world.robots=4".into()],
        )
        .unwrap();
        let out = run::run(config.clone(), 1, &dir.join("a"), true).unwrap();
        assert_eq!(diff(&out.log_path, None, true).unwrap(), 0);
        // Truncated, foreign and missing logs: git bisect's "skip", never "bad".
        let bytes = std::fs::read(&out.log_path).unwrap();
        let cut = dir.join("cut.swlog");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        assert_eq!(diff(&cut, None, true).unwrap(), EXIT_CANNOT_TEST);
        std::fs::write(&cut, b"not a log at all").unwrap();
        assert_eq!(diff(&cut, None, true).unwrap(), EXIT_CANNOT_TEST);
        assert_eq!(
            diff(&dir.join("missing.swlog"), None, true).unwrap(),
            EXIT_CANNOT_TEST
        );
        // A log whose header says seed 1 but whose records are seed 2's: it reads fine and
        // the re-simulation diverges.
        let header = swarmfl_core::log::Header::new(1, config.to_toml());
        let wrong = dir.join("wrong.swlog");
        let mut writer = swarmfl_core::log::LogWriter::create(&wrong, &header).unwrap();
        for record in swarmfl_core::sim::Sim::new(config, 2).unwrap() {
            writer.append(&record).unwrap();
        }
        writer.finish().unwrap();
        assert_eq!(diff(&wrong, None, true).unwrap(), EXIT_DIVERGED);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

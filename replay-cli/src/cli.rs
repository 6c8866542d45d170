//! The command line: the clap types of `swarmfl` and its subcommands, with their help texts.
//! Each subcommand's arguments are one struct that its function in `commands/` takes.

use std::path::PathBuf;
use std::sync::LazyLock;

use clap::{Args, Parser, Subcommand, ValueEnum};
use swarmfl_core::config::{Config, Rule};

/// swarmfl: a deterministic, event-sourced replay engine for blockchain-secured federated
/// learning in robot swarms.
#[derive(Parser, Debug)]
#[command(name = "swarmfl", version = VERSION.as_str(), about)]
pub struct Cli {
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
}

/// What `swarmfl --version` prints after the name: the crate's version and the git commit the
/// binary was built from (the commit every log's header records), e.g. `0.1.0 (commit 5184882…)`.
pub static VERSION: LazyLock<String> = LazyLock::new(|| {
    let commit = swarmfl_core::log::GIT_COMMIT.unwrap_or("unknown: built outside a git checkout");
    format!("{} (commit {commit})", env!("CARGO_PKG_VERSION"))
});

/// Which configuration to use: a preset, a TOML file over it, and overrides.
#[derive(Args, Debug, Clone)]
pub struct ConfigArgs {
    /// The preset to start from (see `swarmfl presets`); default `paper`.
    #[arg(long)]
    pub preset: Option<String>,
    /// A TOML file overlaid on the preset (it may name its own `preset`).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Overrides, `key.path=value`, applied in order (e.g. `--set world.robots=30`); the help
    /// names the rules `contract.rule` takes, from the registry ([`set_help`]).
    #[arg(long = "set", value_name = "KEY=VALUE", help = set_help())]
    pub overrides: Vec<String>,
}

impl ConfigArgs {
    /// The configuration these arguments name.
    pub fn resolve(&self) -> anyhow::Result<Config> {
        Ok(Config::resolve(
            self.preset.as_deref(),
            self.config.as_deref(),
            &self.overrides,
        )?)
    }
}

/// The help of `--set`: it names every built-in rule, in the registry's order, so a new rule
/// is in the help by its line in the registry.
fn set_help() -> String {
    let names = Rule::ALL.map(Rule::name);
    let (last, rest) = names.split_last().expect("the registry lists rules");
    format!(
        "Overrides, `key.path=value`, applied in order (e.g. `--set world.robots=30`). \
         `contract.rule` takes {} or {last} (docs/GUIDE.md)",
        rest.join(", ")
    )
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Simulate a run: writes DIR/run.swlog and DIR/summary.json.
    Run(RunArgs),
    /// Check a log. By default: the hash chain is intact (no frame was damaged or cut) and its
    /// events fold to every checkpoint it records ("consistent"). The chain is not keyed, so
    /// this does not show that the header (seed, configuration) or the records are those the
    /// run made: an edited log whose chain was recomputed passes. --resimulate re-runs the
    /// header's seed and configuration and compares every record byte for byte ("bit-exact").
    Replay(ReplayArgs),
    /// Draw the arena, obstacles, robots (Byzantine ones marked) and radio links at a simulated
    /// time or right after a block of the final canonical chain (SVG or PNG).
    Snapshot(SnapshotArgs),
    /// Write one self-contained HTML file to watch a run in a browser (no network, no server):
    /// the arena with robots, ids, Byzantine marks and radio links, animated with a scrubber
    /// that also jumps by block height; each robot's tokens, the loss per round and the chain
    /// with its forks and reorgs up to the time shown. `run.html#t=600` or `#block=40` opens
    /// at that moment. It checks the hash chain and every checkpoint it folds, as `replay`
    /// does without --resimulate (not that the header is the run's); a damaged record is
    /// refused (exit 1), a cut log shown up to the cut with a warning.
    View(ViewArgs),
    /// Compare two logs: header differences and the first diverging record (exit 1 if they
    /// differ, 2 if one cannot be read). With --resimulate, compare one log with a re-simulation under this build: exit
    /// 0 identical, 1 diverged, 125 when the log cannot be read (`git bisect run` skips).
    Diff(DiffArgs),
    /// Regression fixtures: `regenerate` re-makes fixtures/logs and fixtures/expected.toml
    /// from fixtures/manifest.toml (after an intentional change; see CHANGELOG.md).
    Fixtures(FixturesArgs),
    /// Show block H of the final canonical chain: the block, the contract state after it, every
    /// node's head and the world at that moment (and the time it took). It checks the hash
    /// chain and every checkpoint it folds, as `replay` does without --resimulate (not that
    /// the header is the run's); a damaged record is refused (exit 1), a cut log inspected up
    /// to the cut with a warning.
    Inspect(InspectArgs),
    /// Find the first block of the final canonical chain where a predicate holds (exit 1 if none);
    /// in a baseline run (no blocks), the first checkpoint by time (time, round, loss,
    /// heldout_loss).
    #[command(after_long_help = BISECT_HELP)]
    Bisect(BisectArgs),
    /// Continue a run from block H of its final canonical chain under a changed configuration.
    /// The fork's log records its parent's final hash, the height and the overrides, holds the
    /// parent's records up to the fork point (re-simulated and checked byte for byte against
    /// the parent) and replays on its own.
    #[command(after_long_help = FORK_HELP)]
    Fork(ForkArgs),
    /// Who caused it: each robot's influence on an outcome (an expression over bisect's
    /// identifiers, the held-out loss by default) read at the end, at --block N or at the first
    /// block where --until holds: the outcome minus the outcome of the exact re-simulation in
    /// which the robot never submits (`learn.withheld = [k]`), and for a Byzantine robot also
    /// as if it had learned honestly (`byzantine.as_honest = [k]`). Largest influence first;
    /// prints what the counterfactuals cost.
    Blame(BlameArgs),
    /// Whole-run contributions: each robot's leave-one-out and Shapley value (permutation
    /// sampling, --samples orders drawn with --seed, with the standard error) of an outcome,
    /// from exact re-simulations in which only some robots submit.
    Contributions(ContributionsArgs),
    /// Write CSV tables of a run: rounds.csv (per closed round: time, loss, held-out loss,
    /// accepted, outliers; a gossip or central run: per aggregation), submissions.csv (every
    /// counted submission of every closed round: outcome, distance, samples claimed, reward),
    /// balances.csv (every robot's balance after every block of the final canonical chain),
    /// chain_bytes.csv (every node's chain size at every sealing) and trajectories.csv (the
    /// samples of every robot's data set at the end of the run). A baseline run has no blocks
    /// or tokens: rounds.csv and trajectories.csv only.
    Export(ExportArgs),
    /// Where the Byzantine and the honest submissions sat in their rounds' rankings, over many
    /// runs (logs, or a sweep's results made with --keep-logs): per round, run and point
    /// (ranking x Byzantine kind x count) the distance to the shared model over the round's
    /// median distance, the rank, the share penalised, the tokens gained; rounds.csv, runs.csv,
    /// points.csv, points.json and figures (SVG, PNG).
    Ranking(RankingArgs),
    /// Bytes sent and stored per node over time, from logs (or a sweep's results made with
    /// --keep-logs): every --every simulated seconds and at the end, the mean and the min,
    /// median and max over nodes of the summary's `bytes_sent_per_robot_mean` (chain: ledger
    /// gossip; gossip: stigmergy messages; central: uploads; lost ones included) and
    /// `bytes_stored_per_robot_mean` (chain: every block a node holds; gossip: its replica;
    /// central: its model). The last row is the summary's end values, bit for bit. Prints a
    /// table per run (MB), or CSV (bytes) with --csv; --out DIR writes DIR/traffic.csv and
    /// figures per swarm size (SVG, PNG).
    #[command(after_long_help = TRAFFIC_HELP)]
    Traffic(TrafficArgs),
    /// Run one of the paper's experiments (or a shard of it): every configuration point x seed.
    #[command(long_about = SWEEP_HELP)]
    Sweep(SweepArgs),
    /// Merge a sweep's results: means and 95 % CIs, the paper's figures (SVG, PNG), report.md.
    Report(ReportArgs),
    /// Check that committed studies come from this build: every result file's configuration
    /// under today's presets, the report re-made from the results, and a few tasks per
    /// experiment re-run (the fastest by recorded wall time) compared field by field, wall-clock
    /// fields apart. Exits 1 naming each file that differs. A study whose README.md has a line
    /// `Stale: <why>` is reported as stale and not checked.
    Recheck(RecheckArgs),
    /// A seeded fault campaign: each seed draws a configuration, Byzantine behaviours and a
    /// fault schedule, runs it and checks invariants at every block (conservation, validity,
    /// agreement after heals, liveness). Exits 1 on a violation, naming the seed and the
    /// command that replays it.
    Chaos(ChaosArgs),
    /// List the presets.
    Presets,
    /// Print the fully resolved configuration as TOML.
    Config {
        #[command(flatten)]
        config: ConfigArgs,
    },
    /// Time one subsystem and print its figures.
    Bench(BenchArgs),
    /// The data volume: samples per robot of the world alone (no learning, no ledger) per
    /// behaviour, swarm size and seed, beside Flow-FL's published dataset counts.
    DataVolume(DataVolumeArgs),
    /// One size of `bench scale`, run in a child process so that its peak RSS is its own:
    /// prints one JSON line.
    #[command(hide = true)]
    BenchScaleOne(BenchScaleOneArgs),
}

/// The arguments of `swarmfl run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    pub config: ConfigArgs,
    /// The seed: with the configuration, it determines the whole run.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory. Default `runs/<preset>-seed<N>` for a preset as it is, and
    /// `runs/<preset>-seed<N>-<8 hex digits>` with --set or --config (a digest of the sorted
    /// overrides and the file's contents), so every configuration has its own folder. A run of
    /// the same configuration there is replaced (and said so); one of another configuration is
    /// refused without --force. A folder named here is replaced, saying what it held.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the run in the default folder even if it is of another configuration.
    #[arg(long)]
    pub force: bool,
    /// No progress bar and no summary on stdout.
    #[arg(long)]
    pub quiet: bool,
    /// Watch the run while it goes: serve the viewer (the page of `swarmfl view`) on
    /// http://127.0.0.1:PORT/ (loopback only), its frames following the log as it grows. The
    /// page says when the run has ended, and keeps the whole run to scrub; the server stops
    /// with the run (a few seconds later, while a page is still asking) or on Ctrl-C. The log
    /// and summary are the same as without --live.
    #[arg(long)]
    pub live: bool,
    /// The live view's port (0: any free port; the URL is printed).
    #[arg(long, default_value_t = 8700, requires = "live")]
    pub port: u16,
}

/// The arguments of `swarmfl replay`.
#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The log (run.swlog).
    pub log: PathBuf,
    /// Re-simulate from the header's seed and configuration and compare every record byte
    /// for byte: the only check that the records are those of the header (as long as the run
    /// takes to simulate).
    #[arg(long)]
    pub resimulate: bool,
}

/// The arguments of `swarmfl snapshot`.
#[derive(Args, Debug)]
pub struct SnapshotArgs {
    /// The log (run.swlog).
    pub log: PathBuf,
    /// Simulated time in seconds (the state after the last tick at or before it).
    #[arg(long, conflicts_with = "block", required_unless_present = "block")]
    pub time: Option<f64>,
    /// Height on the final canonical chain (the state right after its sealing).
    #[arg(long)]
    pub block: Option<u64>,
    /// Output file: `.svg` or `.png`.
    #[arg(long)]
    pub out: PathBuf,
}

/// The arguments of `swarmfl view`.
#[derive(Args, Debug)]
pub struct ViewArgs {
    /// The log (run.swlog).
    pub log: PathBuf,
    /// Output file (e.g. run.html).
    #[arg(long)]
    pub out: PathBuf,
    /// A blame report (`swarmfl blame LOG --json > blame.json`) to show as a per-robot
    /// influence bar beside the tokens.
    #[arg(long, value_name = "BLAME_JSON")]
    pub blame: Option<PathBuf>,
}

/// The arguments of `swarmfl diff`.
#[derive(Args, Debug)]
pub struct DiffArgs {
    /// The first log.
    pub a: PathBuf,
    /// The second log (omit with --resimulate).
    pub b: Option<PathBuf>,
    /// Compare `a` with a fresh re-simulation of its header's seed and configuration.
    #[arg(long)]
    pub resimulate: bool,
}

/// The arguments of `swarmfl fixtures`.
#[derive(Args, Debug)]
pub struct FixturesArgs {
    /// What to do.
    pub action: FixturesAction,
    /// The fixtures folder.
    #[arg(long, default_value = "fixtures")]
    pub dir: PathBuf,
}

/// The arguments of `swarmfl inspect`.
#[derive(Args, Debug)]
pub struct InspectArgs {
    /// The log (run.swlog).
    pub log: PathBuf,
    /// Height on the final canonical chain (the best node's chain at the end; 0 = genesis).
    #[arg(long, required_unless_present = "time", conflicts_with = "time")]
    pub block: Option<u64>,
    /// A baseline run (`learn.aggregation` gossip or central, no blocks): the state at the
    /// last checkpoint at or before this simulated time, s.
    #[arg(long)]
    pub time: Option<f64>,
    /// Narrow to one robot's view too (its node, balance, data, last learning phase).
    #[arg(long)]
    pub robot: Option<u32>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Ignore (and do not write) the sidecar index LOG.idx: fold the whole log.
    #[arg(long)]
    pub no_index: bool,
}

/// The arguments of `swarmfl bisect`.
#[derive(Args, Debug)]
pub struct BisectArgs {
    /// The log (run.swlog).
    pub log: PathBuf,
    /// The predicate, e.g. "byzantine_tokens > honest_tokens" (see --help for the grammar).
    #[arg(long)]
    pub until: String,
    /// Declare the predicate monotone (false, then true for good): binary search with
    /// O(log n) evaluations instead of a scan.
    #[arg(long)]
    pub monotone: bool,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// Where `blame` and `contributions` read the outcome.
#[derive(Args, Debug)]
pub struct OutcomeArgs {
    /// The log (run.swlog) of a chain run made without plug-ins.
    pub log: PathBuf,
    /// The outcome: an expression over bisect's identifiers (`swarmfl bisect --help`).
    #[arg(long, default_value = "heldout_loss")]
    pub outcome: String,
    /// Read the outcome at the first block where this condition holds.
    #[arg(long, conflicts_with = "block")]
    pub until: Option<String>,
    /// Read the outcome at this block of the final canonical chain.
    #[arg(long)]
    pub block: Option<u64>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// No progress lines.
    #[arg(long)]
    pub quiet: bool,
}

/// The arguments of `swarmfl blame`.
#[derive(Args, Debug)]
pub struct BlameArgs {
    #[command(flatten)]
    pub outcome: OutcomeArgs,
    /// Blame only these robots (repeatable; default: every robot).
    #[arg(long = "robot", value_name = "ID")]
    pub robots: Vec<u32>,
    /// Leave out the "as if honest" counterfactuals of the Byzantine robots.
    #[arg(long)]
    pub no_honest: bool,
}

/// The arguments of `swarmfl contributions`.
#[derive(Args, Debug)]
pub struct ContributionsArgs {
    #[command(flatten)]
    pub outcome: OutcomeArgs,
    /// Sampled orders for the Shapley values (0: leave-one-out only).
    #[arg(long, default_value_t = 0)]
    pub samples: u32,
    /// The seed of the sampled orders.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// The arguments of `swarmfl fork`.
#[derive(Args, Debug)]
pub struct ForkArgs {
    /// The parent log (run.swlog).
    pub log: PathBuf,
    /// Height on the parent's final canonical chain (at least 1).
    #[arg(long)]
    pub at: u64,
    /// Override a key from the fork point on (repeatable), e.g. --set contract.security=true.
    #[arg(long = "set", value_name = "KEY=VALUE", required = true)]
    pub overrides: Vec<String>,
    /// Output directory, never the parent's own. Default: beside the parent's folder,
    /// `<parent folder>-fork-at-H-<8 hex digits of the sorted overrides>`; a fork of another
    /// configuration there is refused without --force. A folder named here is replaced, saying
    /// what it held.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the run in the default folder even if it is of another configuration.
    #[arg(long)]
    pub force: bool,
    /// No progress bar and no summary.
    #[arg(long)]
    pub quiet: bool,
}

/// The arguments of `swarmfl export`.
#[derive(Args, Debug)]
pub struct ExportArgs {
    /// The log (run.swlog).
    pub log: PathBuf,
    /// Output directory (created).
    #[arg(long)]
    pub out: PathBuf,
}

/// The arguments of `swarmfl ranking`.
#[derive(Args, Debug)]
pub struct RankingArgs {
    /// Logs (run.swlog), or directories searched for them recursively (e.g. a sweep's results
    /// made with --keep-logs).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output directory (created).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write submissions.csv: every counted submission of every run (large).
    #[arg(long)]
    pub submissions: bool,
}

/// The arguments of `swarmfl traffic`.
#[derive(Args, Debug)]
pub struct TrafficArgs {
    /// Logs (run.swlog), or directories searched for them recursively (e.g. a sweep's results
    /// made with --keep-logs).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// The period of the rows, simulated seconds (0.001 to 1000000); the end of the run is
    /// always the last row.
    #[arg(long, default_value_t = 100.0, value_name = "SECONDS", allow_negative_numbers = true, value_parser = period_s)]
    pub every: f64,
    /// Print every run's rows as one CSV (bytes per node) instead of tables.
    #[arg(long, conflicts_with = "out")]
    pub csv: bool,
    /// Write DIR/traffic.csv (the --csv text) and the figures traffic-sent-<N>,
    /// traffic-stored-<N> (per swarm size N: a line per aggregation over time),
    /// traffic-sent-rate and traffic-stored-rate (growth per node over the run's second half
    /// versus the size), SVG and PNG; print per run the end values and growth.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// The arguments of `swarmfl sweep`.
#[derive(Args, Debug)]
pub struct SweepArgs {
    /// The experiment: e0-baselines, e1-expiration, e1-faulty, e2-faulty, e2-malicious,
    /// e3-smart, e4-robustness, e5-smart-defence, e2-malicious-authors, e3-smart-authors,
    /// e2-malicious-authors-timing, e3-smart-authors-timing, e3-smart-authors-code,
    /// e2-malicious-authors-gas, e3-smart-authors-gas,
    /// e6-scale, e6-scale-1000, e6-scale-1000-gossip, e4-heterogeneity or
    /// e4-heterogeneity-measure.
    /// Omit it to sweep a --grid.
    pub experiment: Option<String>,
    /// A grid axis over any configuration key, `KEY=V1,V2,...` (repeat for more axes: every
    /// combination is a point, e.g. `--grid contract.rule=median,krum --grid
    /// byzantine.count=1,3`). Results go to DIR/grid-<preset>/<key=value+...>/seed<N>.json.
    #[arg(long, value_name = "KEY=V1,V2")]
    pub grid: Vec<String>,
    /// The preset a --grid starts from (default paper); an experiment has its own.
    #[arg(long)]
    pub preset: Option<String>,
    /// Results directory: one DIR/<experiment>/<point>/seed<N>.json per task.
    #[arg(long)]
    pub out: PathBuf,
    /// Runs (seeds 1..=N) per point; default the paper's (5, 10, 20, 20, 18), 1 for a grid.
    #[arg(long, visible_alias = "seeds")]
    pub runs: Option<u32>,
    /// Runs in parallel; default the number of cores.
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Run only shard I of N: the tasks whose index modulo N is I.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// The shard count when the index comes from JOB_COMPLETION_INDEX (or SWARMFL_SHARDS).
    #[arg(long)]
    pub shards: Option<u32>,
    /// Overrides for every task, `key.path=value` (e.g. `--set run.duration_s=600`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Keep each run's log in DIR/<experiment>/<point>/seed<N>/ (default: deleted).
    #[arg(long)]
    pub keep_logs: bool,
}

/// The arguments of `swarmfl report`.
#[derive(Args, Debug)]
pub struct ReportArgs {
    /// The results directory of one or more sweeps (shards merged by copying into it).
    pub dir: PathBuf,
    /// Report directory.
    #[arg(long)]
    pub out: PathBuf,
}

/// The arguments of `swarmfl recheck`.
#[derive(Args, Debug)]
pub struct RecheckArgs {
    /// Study directories, each with a sweep's `results/` and the report made from it
    /// (e.g. reproduction/full-study).
    pub dirs: Vec<PathBuf>,
    /// Tasks re-run per experiment of each study (0: only the configuration and report checks).
    #[arg(long, default_value_t = 1)]
    pub tasks: usize,
    /// Re-runs in parallel; default the number of cores.
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Re-run only tasks whose recorded wall time is at most this many seconds (CI's bound, so
    /// a study of 1000-robot runs can be committed and still have its configurations and
    /// report checked). An experiment with no task under it is named in the output as not
    /// re-run, never skipped silently.
    #[arg(long, value_name = "S")]
    pub max_task_s: Option<f64>,
    /// Re-run only tasks of this experiment (repeatable; default every experiment). The
    /// configuration and report checks still cover every file.
    #[arg(long = "experiment", value_name = "NAME")]
    pub experiments: Vec<String>,
}

/// The arguments of `swarmfl chaos`.
#[derive(Args, Debug)]
pub struct ChaosArgs {
    /// How many seeds.
    #[arg(long, default_value_t = 10)]
    pub seeds: u64,
    /// The first seed.
    #[arg(long, default_value_t = 0)]
    pub first_seed: u64,
    /// Simulated seconds per run (`run.duration_s` of each run).
    #[arg(long, default_value_t = 600.0, value_name = "SECONDS", allow_negative_numbers = true, value_parser = duration_s)]
    pub duration: f64,
    /// Print the report as JSON (and each seed's outcome on stderr as one JSON line as soon
    /// as it finishes).
    #[arg(long)]
    pub json: bool,
    /// Write each seed's drawn configuration to DIR/seed-N.toml: `swarmfl run --config
    /// DIR/seed-N.toml --seed N` then writes the log of that run (for inspect, bisect, view).
    #[arg(long, value_name = "DIR")]
    pub configs: Option<PathBuf>,
}

/// The arguments of `swarmfl bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Which subsystem.
    pub target: BenchTarget,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
    /// `scale` only: the swarm sizes, comma-separated.
    #[arg(long, value_name = "N,N,..")]
    pub robots: Option<String>,
    /// `scale` only: simulated seconds per size (default 300; `run.duration_s` of each run).
    #[arg(long = "duration", visible_alias = "duration-s", value_name = "SECONDS", allow_negative_numbers = true, value_parser = duration_s)]
    pub duration_s: Option<f64>,
    /// `scale` only: the seed of every size's run (default 1).
    #[arg(long)]
    pub seed: Option<u64>,
    /// `scale` only: a configuration override applied to every size after the scaling (e.g.
    /// `--set contract.protocol=buffered --set learn.training_period_s=100`); repeatable.
    /// `world.robots`, `world.arena_side_m`, `world.cylinders`, `world.boxes` and
    /// `run.duration_s` are the benchmark's own and refused here.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// The arguments of `swarmfl data-volume`.
#[derive(Args, Debug)]
pub struct DataVolumeArgs {
    #[command(flatten)]
    pub config: ConfigArgs,
    /// The behaviours, comma-separated (`world.behaviour` values; default all four).
    #[arg(long, default_value = "avoidance,flocking,foraging,mixed")]
    pub behaviours: String,
    /// The swarm sizes, comma-separated (the arena stays as configured, as in Flow-FL).
    #[arg(long, default_value = "15,60")]
    pub robots: String,
    /// The seeds, comma-separated.
    #[arg(long, default_value = "1,2,3")]
    pub seeds: String,
    /// Simulated seconds of each run (Flow-FL's dataset: 5000).
    #[arg(long, default_value_t = 5000.0)]
    pub duration_s: f64,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
    /// Measure each behaviour under its own Flow-FL experiment's preset (`flowfl` for
    /// avoidance, `flowfl-flocking`, `flowfl-foraging`, `flowfl-mixed`) instead of --preset
    /// with `world.behaviour` set; --config and --set apply on top of each.
    #[arg(long, conflicts_with = "preset")]
    pub experiments: bool,
}

/// The arguments of `swarmfl bench-scale-one`.
#[derive(Args, Debug)]
pub struct BenchScaleOneArgs {
    /// Robots.
    #[arg(long)]
    pub robots: u32,
    /// Simulated seconds.
    #[arg(long = "duration", visible_alias = "duration-s", value_name = "SECONDS", allow_negative_numbers = true, value_parser = duration_s)]
    pub duration_s: f64,
    /// The seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Overrides applied after the scaling.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// A `--duration` in simulated seconds: the range and message of `run.duration_s`, which it
/// sets (so `-5` is a duration out of range, not an unknown flag).
fn duration_s(text: &str) -> Result<f64, String> {
    let value: f64 = text
        .parse()
        .map_err(|_| format!("`{text}` is not a number of seconds"))?;
    let mut config = swarmfl_core::config::Preset::Smoke.config();
    config.run.duration_s = value;
    match config.validate() {
        Err(swarmfl_core::config::ConfigError::OutOfRange { allowed, .. }) => Err(format!(
            "{value} seconds is out of range; allowed: {allowed} (as `run.duration_s`)"
        )),
        _ => Ok(value),
    }
}

/// A `--every` in simulated seconds: a positive whole number of milliseconds up to
/// `inspect::MAX_PERIOD_MS`.
fn period_s(text: &str) -> Result<f64, String> {
    let value: f64 = text
        .parse()
        .map_err(|_| format!("`{text}` is not a number of seconds (e.g. --every 100)"))?;
    let max_s = swarmfl_core::inspect::MAX_PERIOD_MS as f64 / 1000.0;
    let ms = value * 1000.0;
    if !(value.is_finite() && (0.001..=max_s).contains(&value)) {
        return Err(format!(
            "{text} seconds cannot sample a run: give a period from 0.001 to {max_s} s (e.g. --every 100)"
        ));
    }
    if (ms - ms.round()).abs() > 1e-6 {
        return Err(format!(
            "{text} seconds is not a whole number of milliseconds, the log's clock: e.g. --every {}",
            ms.round() / 1000.0
        ));
    }
    Ok(value)
}

/// The long help of `swarmfl traffic`, after the options.
const TRAFFIC_HELP: &str = "\
The row at time t holds every record before t (as summary.json's ledger.chain_bytes samples):
the first, at 0, is genesis; the last, at the run's end, holds every record. Each log is folded
once, checking every checkpoint; a truncated or altered log is an error that names the file.

Examples:
  swarmfl traffic runs/paper-seed1/run.swlog --every 500
  swarmfl traffic runs/paper-seed1/run.swlog --csv > traffic.csv
  swarmfl sweep e6-scale --runs 1 --keep-logs --out results
  swarmfl traffic results/e6-scale --out bytes-over-time";

/// The long help of `swarmfl bisect`, after the options: the predicate language.
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
  byzantine_tokens  mean balance of the Byzantine robots, tokens (NaN without any)
  honest_tokens     mean balance of the honest robots, tokens (NaN without any)
  byzantine_wealth  byzantine_tokens plus the group's stakes in the current round, per robot
  honest_wealth     honest_tokens plus the group's stakes in the current round, per robot
  byzantine_sum     total balance of the Byzantine robots, tokens
  honest_sum        total balance of the honest robots, tokens
  byzantine_share   byzantine_sum / (byzantine_sum + honest_sum), 0..1
  accepted          accepted submissions in the current round
  outliers          outlier submissions in the current round
  pool              tokens held by the contract (stakes and carried remainders)
  robots            number of robots
  balance[i]        robot i's balance after the block, tokens
  node[i].height    height of node i's head right after the block was sealed
Examples: \"byzantine_tokens > honest_tokens\", \"loss > 0.1\", \"round >= 50\",
\"node[3].height + 5 < node[0].height\".
Both modes first fold the whole log once (checking every checkpoint) to learn the final
canonical chain; the search then evaluates the per-block values in memory.";

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum FixturesAction {
    /// Re-run every fixture of the manifest and rewrite the expected hashes.
    Regenerate,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum BenchTarget {
    /// Physics + sensing + data.
    World,
    /// One local training of the reference workload.
    Train,
    /// Whole `paper` runs at the paper's density at growing swarm sizes (default 15, 60, 240,
    /// 960 robots, 300 simulated s each; `--set` changes the protocol, the training period, ...):
    /// wall, CPU and per-part time per robot-simulated-second, peak RSS, model versions and the
    /// held-out loss per size.
    Scale,
}

/// The long help of `swarmfl fork`, after the options: the fork point and the keys a fork may
/// change.
const FORK_HELP: &str =
    "The fork point of block H is the end of the tick in which H was sealed: from there
the robots use the new configuration, and the contract's new rules apply to the blocks sealed
after it (activation by block timestamp; the round open on a chain when it crosses is restarted
and its stakes refunded). Keys a fork may change:

  run.duration_s                     the run ends at the new time
  learn.* (not lstm_units)           the next trainings' hyper-parameters and schedule
  contract.security, stake_tokens, quorum_fraction, outlier_threshold, penalised_ranks,
  rule, assumed_f, reward_weights, median, fedavg_rounding, int48_products, threshold,
  rank_key, rank_ties, rank_order, payout_rounding, pool, defence, defence_refund_percent
  byzantine.*                        which robots misbehave, and how
  output.*

Example: what if security had been on from block 200?
  swarmfl run --preset e2-faulty --set contract.security=false --seed 1 --out runs/nosec
  swarmfl fork runs/nosec/run.swlog --at 200 --set contract.security=true --out runs/sec-at-200
  swarmfl replay --resimulate runs/sec-at-200/run.swlog   # bit-exact on its own
  swarmfl diff runs/nosec/run.swlog runs/sec-at-200/run.swlog   # first divergence: the fork";

/// The long help of `swarmfl sweep`: the task list and sharding.
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
  e4-benchmark   <behaviour>--<rule>--<attack>--<count>: {flocking,mixed,avoidance} x 16
                 rules (12, 4 behind nnm) x (clean + 4 attacks x {3, 5}), 5000 s       3 runs
  e4-gate        <behaviour>--gate+<rule>--<attack>--<count>: e4-benchmark's median and krum
                 points at {0, 5} behind the paper's threshold (contract.threshold_gate) 3 runs
  e5-smart-defence  <defence>--<attack>--<count>: defences none, agreement, innovation x
                 (smart 0..7, smart-then-collude 3, 5, 7, faulty 3, malicious 3)       3 runs
  e2-malicious-authors, e3-smart-authors  e2-malicious and e3-smart under the authors'
                 contract (preset authors: docs/CONTRACT.md's options at their values)  20, 18 runs
  e2-malicious-authors-timing, e3-smart-authors-timing  the same under the authors'
                 timing too (preset authors-timing: learn.timing = authors)            20, 18 runs
  e3-smart-authors-code  e3-smart-authors-timing with the code's smart robot
                 (byzantine.variant = authors)                                          18 runs
  e2-malicious-authors-gas, e3-smart-authors-gas  the -authors-timing two with the
                 authors' gas (contract.engine = evm, contract.gas_limit = estimate; a build
                 with --features evm)                                                   20, 18 runs
  e6-scale       {rounds,buffered,matched,gossip}-{15,60,240}, buffered-240-faulty-24
                 (paper density, a training every 100 s; matched: the buffered ideal)  3 runs
  e6-scale-1000  {rounds,buffered,matched}-1000                                         2 runs
  e6-scale-1000-gossip  gossip-1000                                                     2 runs
  e4-heterogeneity  alpha-<alpha>--<rule>--<attack>--<count>: home-range alpha {inf,10,1,
                 0.3,0.1} x 9 rules x (clean + 3 attacks x {3, 5} Byzantine), 5000 s   5 runs
  e4-heterogeneity-measure  alpha-{inf,10,1,0.3,0.1}-{15,60}: world.home_range.alpha x
                 size at the paper's density, 3600 s world-only runs (no training)      3 runs

Task list (fixed): point-major, task index = point_index * runs + (seed - 1), points in the
order above. Shard I/N runs the tasks with index % N == I. The shard comes from --shard I/N,
else SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN (MIN 0 if unset) of SLURM_ARRAY_TASK_COUNT
(or --shards N), else JOB_COMPLETION_INDEX of --shards N or SWARMFL_SHARDS; else all tasks.

Each task writes DIR/<experiment>/<point>/seed<N>.json (the run's summary plus a `sweep`
section) atomically; existing, parseable result files are skipped, so re-running the same
command resumes a sweep and retries failed tasks.";

#[cfg(test)]
mod tests {
    use super::FORK_HELP;
    use swarmfl_core::config::{Rule, RECONFIGURABLE};

    /// `run --help` (the `--set` flag) names every aggregation rule.
    #[test]
    fn the_set_help_lists_every_rule() {
        use clap::CommandFactory;
        let mut cmd = super::Cli::command();
        let run = cmd.find_subcommand_mut("run").expect("a run subcommand");
        let help = run.render_long_help().to_string();
        let words: Vec<&str> = help
            .split(|c: char| !(c.is_alphanumeric() || c == '-'))
            .collect();
        for rule in Rule::ALL {
            assert!(
                words.contains(&rule.name()),
                "`run --help` does not list the rule {}",
                rule.name()
            );
        }
    }

    /// `sweep --help` lists every experiment, each at the start of a line of its table, and
    /// the argument's own help names each one.
    #[test]
    fn the_sweep_help_lists_every_experiment() {
        use clap::CommandFactory;
        let mut cmd = super::Cli::command();
        let sweep = cmd
            .find_subcommand_mut("sweep")
            .expect("a sweep subcommand");
        let help = sweep.render_long_help().to_string();
        for name in swarmfl_study::experiments::EXPERIMENTS {
            let in_table = super::SWEEP_HELP.lines().any(|line| {
                let line = line.trim_start();
                line.starts_with(&format!("{name} "))
                    || line.starts_with(&format!("{name}, "))
                    || line.contains(&format!(", {name} "))
            });
            assert!(in_table, "`sweep --help`'s table has no line for {name}");
            let words: Vec<&str> = help
                .split(|c: char| !(c.is_alphanumeric() || c == '-'))
                .collect();
            assert!(words.contains(&name), "`sweep --help` does not name {name}");
        }
    }

    /// `fork --help` lists every key a fork may change: a key, its table's `.*`, or (for the
    /// contract's many keys, listed after `contract.`) its name as a word.
    #[test]
    fn the_fork_help_lists_every_reconfigurable_key() {
        let words: Vec<&str> = FORK_HELP
            .split(|c: char| !(c.is_alphanumeric() || c == '_'))
            .collect();
        for key in RECONFIGURABLE {
            let (table, name) = key.split_once('.').expect("a dotted key");
            let listed = FORK_HELP.contains(key)
                || FORK_HELP.contains(&format!("{table}.*"))
                || (table == "contract" && words.contains(&name));
            assert!(
                listed,
                "`fork --help` does not list the reconfigurable key {key}"
            );
        }
    }
}

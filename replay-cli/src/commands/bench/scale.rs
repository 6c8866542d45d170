//! `swarmfl bench scale`: the cost of a whole run per robot and simulated second as the swarm
//! grows at the paper's density (issue 14).
//!
//! Each swarm size is the `paper` preset with `world.robots = N`, the arena side grown to keep
//! the paper's 15 robots per 25 m^2 (`world.arena_side_m = 5 * sqrt(N / 15)`), the obstacles
//! scaled with the area (`world.cylinders`, `world.boxes` = 5 * N / 15, rounded) and
//! `run.duration_s` the benchmark's duration; everything else (ledger, contract, learning) is the
//! preset's. Each size runs in a child process of this same binary (the hidden
//! `bench-scale-one` command) through [`swarmfl_study::run::RunRequest`], exactly what `swarmfl run` does, so
//! its peak RSS (`VmHWM`) is that size's alone. The child reports the run's wall time, the
//! process CPU time, the driver's per-part wall and CPU times (the `timing` of `summary.json`)
//! and its peak RSS; the parent divides by robots x simulated seconds and compares each size
//! with the 60-robot one (the acceptance: the largest size within 2x).

use std::process::Command;

use anyhow::Context;
use swarmfl_core::config::{Config, Preset};

/// The swarm sizes run by default.
pub const DEFAULT_ROBOTS: &str = "15,60,240,960";
/// Simulated seconds per size by default: 15..240 robots take seconds, 960 robots about 1.5
/// min on 2 cores (9 min before the ledger's cost per robot stopped growing with the swarm).
pub const DEFAULT_DURATION_S: f64 = 300.0;
/// The seed of every run by default.
pub const DEFAULT_SEED: u64 = 1;
/// The keys the benchmark sets itself, which `--set` may not change.
const OWN_KEYS: [&str; 5] = [
    "world.robots",
    "world.arena_side_m",
    "world.cylinders",
    "world.boxes",
    "run.duration_s",
];

/// What every size runs besides its swarm size: the duration, the seed and the overrides.
#[derive(Clone, Debug)]
pub struct Workload {
    /// Simulated seconds (`run.duration_s`).
    pub duration_s: f64,
    /// The seed of every size's run.
    pub seed: u64,
    /// `KEY=VALUE` overrides applied after the scaling (`--set`).
    pub overrides: Vec<String>,
}

impl Workload {
    /// The paper preset at the default duration and seed, without overrides.
    pub fn paper(duration_s: f64) -> Workload {
        Workload {
            duration_s,
            seed: DEFAULT_SEED,
            overrides: Vec::new(),
        }
    }
}
/// The size the others are compared with when it is run (the acceptance).
const REFERENCE_ROBOTS: u32 = 60;
/// The parts of the driver's timing, as named in `summary.json`'s `timing` (`<part>_s` wall,
/// `<part>_cpu_s` CPU: the driver thread's in that part, plus every other thread's in
/// learning, see `run.rs`).
const PARTS: [&str; 5] = [
    "world",
    "ledger",
    "learning",
    "checkpoint",
    "log_and_summary",
];

/// The `paper` preset at `robots` robots and the paper's density, run for the workload's
/// duration, with its overrides.
pub fn scaled_config(robots: u32, workload: &Workload) -> anyhow::Result<Config> {
    for o in &workload.overrides {
        let key = o.split('=').next().unwrap_or("").trim();
        anyhow::ensure!(
            !OWN_KEYS.contains(&key),
            "--set {o}: `{key}` is set by `bench scale` itself (the swarm size, the paper's density \
             and --duration); choose sizes with --robots and the duration with --duration"
        );
    }
    let duration_s = workload.duration_s;
    let paper = Preset::Paper.config();
    let scale = f64::from(robots) / f64::from(paper.world.robots);
    let obstacles = |n: u32| (f64::from(n) * scale).round() as u32;
    let overrides = vec![
        format!("world.robots={robots}"),
        format!(
            "world.arena_side_m={}",
            paper.world.arena_side_m * scale.sqrt()
        ),
        format!("world.cylinders={}", obstacles(paper.world.cylinders)),
        format!("world.boxes={}", obstacles(paper.world.boxes)),
        format!("run.duration_s={duration_s}"),
    ]
    .into_iter()
    .chain(workload.overrides.iter().cloned())
    .collect::<Vec<_>>();
    Config::resolve(Some("paper"), None, &overrides)
        .with_context(|| format!("the paper preset at {robots} robots ({overrides:?})"))
}

/// Parses `--robots 15,60,240,960`.
pub fn parse_robots(list: &str) -> anyhow::Result<Vec<u32>> {
    let robots = list
        .split(',')
        .map(|s| {
            s.trim()
                .parse::<u32>()
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| {
                    anyhow::anyhow!(
                        "--robots: `{s}` is not a swarm size; give positive integers separated by \
                     commas, e.g. --robots {DEFAULT_ROBOTS}"
                    )
                })
        })
        .collect::<anyhow::Result<Vec<u32>>>()?;
    Ok(robots)
}

/// Peak resident set size of this process (`VmHWM` of /proc/self/status) in KiB.
fn peak_rss_kib() -> anyhow::Result<u64> {
    let status = std::fs::read_to_string("/proc/self/status")
        .context("reading /proc/self/status for the peak RSS (VmHWM)")?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .ok_or_else(|| anyhow::anyhow!("/proc/self/status has no readable VmHWM line"))
}

/// The hidden `bench-scale-one` command: one run at `robots`, its figures as one JSON line on
/// stdout and the run's progress on stderr. The log and summary go to a temporary directory,
/// removed afterwards.
pub fn one(robots: u32, workload: &Workload) -> anyhow::Result<()> {
    let duration_s = workload.duration_s;
    let config = scaled_config(robots, workload)?;
    let world = config.world.clone();
    let dir = std::env::temp_dir().join(format!(
        "swarmfl-bench-scale-{}-{robots}",
        std::process::id()
    ));
    let cpu0 = swarmfl_study::run::process_cpu_s();
    // Progress on stderr (inherited from the parent): a large swarm takes minutes.
    let outcome = swarmfl_study::run::RunRequest::new(config, workload.seed, &dir)
        .run(&crate::progress::Bar::new(false));
    let cpu_s = swarmfl_study::run::process_cpu_s() - cpu0;
    // The directory goes whatever happened; the run's error, if any, is the one reported.
    let removed = std::fs::remove_dir_all(&dir);
    let summary = outcome?.summary;
    removed.with_context(|| format!("removing {}", dir.display()))?;
    let line = serde_json::json!({
        "robots": robots,
        "arena_side_m": world.arena_side_m,
        "cylinders": world.cylinders,
        "boxes": world.boxes,
        "duration_s": duration_s,
        "threads": rayon::current_num_threads(),
        "wall_s": summary.wall_s,
        "cpu_s": cpu_s,
        "timing": summary.timing,
        "peak_rss_kib": peak_rss_kib()?,
        "records": summary.run.records,
        "log_bytes": summary.log_bytes,
        "rounds": summary.run.contract.rounds,
        "canonical_height": summary.run.ledger.canonical_height,
        "mean_neighbours": summary.run.world.mean_neighbours,
        "final_hash": summary.run.final_hash,
        "model_versions": summary.run.contract.rounds,
        "heldout_genesis": summary.run.contract.heldout_loss_initial,
        "heldout_final": summary.run.contract.final_heldout_loss,
        "heldout_median_last_1000s": summary.run.contract.median_heldout_loss_last_1000s,
        "tokens_conserved": summary.run.tokens.total_units_start == summary.run.tokens.total_units_end,
    });
    println!("{}", serde_json::to_string(&line)?);
    Ok(())
}

/// Runs one size in a child process and returns what it printed.
fn child(robots: u32, workload: &Workload) -> anyhow::Result<serde_json::Value> {
    let exe = std::env::current_exe().context("finding this binary to run a size in a child")?;
    let out = Command::new(&exe)
        .args([
            "bench-scale-one",
            "--robots",
            &robots.to_string(),
            "--duration",
            &workload.duration_s.to_string(),
            "--seed",
            &workload.seed.to_string(),
        ])
        .args(
            workload
                .overrides
                .iter()
                .flat_map(|o| ["--set", o.as_str()]),
        )
        .stderr(std::process::Stdio::inherit())
        .output()
        .with_context(|| format!("starting {} bench-scale-one", exe.display()))?;
    anyhow::ensure!(
        out.status.success(),
        "the {robots}-robot run failed ({}); its error is above",
        out.status
    );
    let text = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(text.trim()).with_context(|| {
        format!("the {robots}-robot child printed something that is not its JSON: {text}")
    })
}

/// A number of a child's JSON (0 when absent, which the figures then show).
fn num(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap_or(0.0)
}

/// Runs the benchmark over `robots` and prints its figures (JSON with `json`).
pub fn run(robots: &[u32], workload: &Workload, json: bool) -> anyhow::Result<()> {
    let duration_s = workload.duration_s;
    anyhow::ensure!(!robots.is_empty(), "--robots: give at least one swarm size");
    anyhow::ensure!(
        duration_s.is_finite() && duration_s > 0.0,
        "--duration: {duration_s} is not a positive number of simulated seconds"
    );
    // Every size's configuration is checked before the first (long) run starts.
    for &n in robots {
        scaled_config(n, workload)?;
    }
    let mut sizes = Vec::new();
    for &n in robots {
        if !json {
            eprintln!("bench scale: {n} robots, {duration_s} simulated s ...");
        }
        sizes.push(measure(n, workload)?);
    }
    let report = compare(robots, workload, sizes);
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report, workload);
    }
    Ok(())
}

/// One size, run in a child, with its costs per robot-simulated-second added.
fn measure(n: u32, workload: &Workload) -> anyhow::Result<serde_json::Value> {
    let mut size = child(n, workload)?;
    let robot_s = f64::from(n) * workload.duration_s;
    let per = |s: f64| s / robot_s * 1e6;
    let mut cost = serde_json::Map::new();
    cost.insert("wall".into(), per(num(&size["wall_s"])).into());
    cost.insert("cpu".into(), per(num(&size["cpu_s"])).into());
    for part in PARTS {
        let t = &size["timing"];
        cost.insert(part.into(), per(num(&t[format!("{part}_s")])).into());
        cost.insert(
            format!("{part}_cpu"),
            per(num(&t[format!("{part}_cpu_s")])).into(),
        );
    }
    size["us_per_robot_sim_s"] = cost.into();
    Ok(size)
}

/// The benchmark's report: every size, and the largest size's costs relative to the reference
/// size's (60 robots if measured, else the smallest).
fn compare(
    robots: &[u32],
    workload: &Workload,
    sizes: Vec<serde_json::Value>,
) -> serde_json::Value {
    let reference_robots = if robots.contains(&REFERENCE_ROBOTS) {
        REFERENCE_ROBOTS
    } else {
        *robots.iter().min().expect("not empty")
    };
    let largest = *robots.iter().max().expect("not empty");
    let find = |n: u32| {
        sizes
            .iter()
            .find(|s| s["robots"].as_u64() == Some(u64::from(n)))
            .expect("every size ran")
    };
    let (reference, big) = (find(reference_robots), find(largest));
    let ratio = |key: &str| cost_ratio(big, reference, key);
    let mut ratios = serde_json::Map::new();
    for key in ["wall", "cpu"]
        .into_iter()
        .chain(PARTS)
        .map(String::from)
        .chain(PARTS.map(|p| format!("{p}_cpu")))
    {
        ratios.insert(key.clone(), ratio(&key).into());
    }
    // The fastest-growing of the three simulated parts, by CPU per robot-simulated-second.
    let fastest = ["world", "ledger", "learning"]
        .into_iter()
        .max_by(|a, b| ratio(&format!("{a}_cpu")).total_cmp(&ratio(&format!("{b}_cpu"))))
        .expect("three parts");
    let largest_part = ["world", "ledger", "learning"]
        .into_iter()
        .max_by(|a, b| {
            num(&big["timing"][format!("{a}_cpu_s")])
                .total_cmp(&num(&big["timing"][format!("{b}_cpu_s")]))
        })
        .expect("three parts");
    serde_json::json!({
        "workload": "the paper preset at the paper's density: world.robots = N, world.arena_side_m = 5 * sqrt(N / 15), world.cylinders = world.boxes = round(5 * N / 15), seed 1; each size in its own child process through the code of `swarmfl run`",
        "duration_s": workload.duration_s,
        "seed": workload.seed,
        "overrides": workload.overrides,
        "units": "us_per_robot_sim_s: microseconds of wall (or process CPU) time per robot per simulated second; the parts' times are the driver's (summary.json `timing`): wall on the driver thread; CPU of the driver thread in that part, and for learning also every other thread's (the background trainings)",
        "sizes": sizes,
        "reference_robots": reference_robots,
        "largest_robots": largest,
        "ratio_largest_to_reference": ratios,
        "fastest_growing_part": fastest,
        "largest_part_at_largest_size": largest_part,
    })
}

/// The cost `key` per robot-simulated-second at size `big` over that at `reference`.
fn cost_ratio(big: &serde_json::Value, reference: &serde_json::Value, key: &str) -> f64 {
    num(&big["us_per_robot_sim_s"][key]) / num(&reference["us_per_robot_sim_s"][key])
}

/// The human-readable table of a report from [`compare`].
fn print_table(report: &serde_json::Value, workload: &Workload) {
    let Workload {
        duration_s, seed, ..
    } = workload;
    let largest = num(&report["largest_robots"]);
    let reference_robots = num(&report["reference_robots"]);
    let find = |n: f64| {
        report["sizes"]
            .as_array()
            .and_then(|sizes| sizes.iter().find(|s| num(&s["robots"]) == n))
            .expect("every size ran")
    };
    // From the sizes rather than the report's ratios, which JSON cannot hold when not finite.
    let ratio = |key: &str| cost_ratio(find(largest), find(reference_robots), key);
    let fastest = report["fastest_growing_part"].as_str().unwrap_or("");
    let largest_part = report["largest_part_at_largest_size"]
        .as_str()
        .unwrap_or("");
    println!(
        "paper preset at the paper's density (15 robots / 25 m^2), {duration_s} simulated s per \
         size, seed {seed}; one child process per size"
    );
    if !workload.overrides.is_empty() {
        println!("overrides: {}", workload.overrides.join(" "));
    }
    println!(
        "after |: microseconds of CPU per robot-simulated-second (whole process; per part: the \
         driver thread's, learning also the training threads')"
    );
    println!(
        "{:>6} {:>7} {:>9} {:>9} {:>9} | {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "robots",
        "side_m",
        "wall_s",
        "cpu_s",
        "peak_MiB",
        "total",
        "world",
        "ledger",
        "learning",
        "ckpt",
        "log"
    );
    for s in report["sizes"].as_array().expect("sizes") {
        let c = &s["us_per_robot_sim_s"];
        println!(
            "{:>6.0} {:>7.2} {:>9.2} {:>9.2} {:>9.1} | {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>8.1}",
            num(&s["robots"]),
            num(&s["arena_side_m"]),
            num(&s["wall_s"]),
            num(&s["cpu_s"]),
            num(&s["peak_rss_kib"]) / 1024.0,
            num(&c["cpu"]),
            num(&c["world_cpu"]),
            num(&c["ledger_cpu"]),
            num(&c["learning_cpu"]),
            num(&c["checkpoint_cpu"]),
            num(&c["log_and_summary_cpu"]),
        );
    }
    println!(
        "{:>6} {:>9} {:>11} {:>11} {:>11} {:>9} {:>9}",
        "robots", "versions", "heldout_gen", "median_last", "final", "median/gen", "conserved"
    );
    for s in report["sizes"].as_array().expect("sizes") {
        let genesis = num(&s["heldout_genesis"]);
        let median = s["heldout_median_last_1000s"].as_f64();
        println!(
            "{:>6.0} {:>9.0} {:>11.4} {:>11} {:>11.4} {:>9} {:>9}",
            num(&s["robots"]),
            num(&s["model_versions"]),
            genesis,
            median.map_or("-".to_string(), |m| format!("{m:.4}")),
            s["heldout_final"].as_f64().unwrap_or(f64::NAN),
            median.map_or("-".to_string(), |m| format!("{:.4}", m / genesis)),
            s["tokens_conserved"]
                .as_bool()
                .map_or("-", |c| if c { "yes" } else { "NO" }),
        );
    }
    println!(
        "cost per robot-simulated-second, {largest} robots / {reference_robots} robots: wall {:.2}x, \
         CPU {:.2}x (world {:.2}x, ledger {:.2}x, learning {:.2}x)",
        ratio("wall"),
        ratio("cpu"),
        ratio("world_cpu"),
        ratio("ledger_cpu"),
        ratio("learning_cpu"),
    );
    println!(
        "fastest-growing part: {fastest}; largest part at {largest} robots: {largest_part} \
         (issue 14's acceptance: the CPU ratio within 2x)"
    );
}

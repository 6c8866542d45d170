//! `swarmfl bench world`: physics + sensing + data throughput (issue: the world).
//!
//! Times `Controllers::decide` + `World::apply` on one thread (world construction, including
//! the held-out set, is timed separately): 15 robots x 50,000 ticks of the paper preset, and
//! 150 robots in an arena scaled to keep the density (side x sqrt(10), obstacles x 10) for
//! 5,000 ticks; medians of 3 runs. Also reports the data yield (samples per robot per 600 s)
//! of the `paper` and `reference` presets from those runs.
//!
//! Then the parallel world (issue 56, `core/src/world/par.rs`): 1000 robots at the paper's
//! density for 1,000 ticks on a pool of one thread and on a pool of two, the speed-up of two
//! over one (the acceptance: at least 1.6x) and whether the two end in the same
//! digest (they must).

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use swarmfl_core::config::{Config, Preset};
use swarmfl_core::world::{Controllers, Workers, World, WorldStats};

const RUNS: usize = 3;
const SEED: u64 = 1;

#[derive(Serialize)]
struct Case {
    name: String,
    robots: u32,
    arena_side_m: f64,
    ticks: u64,
    /// Median wall time of the tick loop over the runs.
    wall_s: f64,
    /// Median world construction time (placement and held-out set).
    build_s: f64,
    robot_ticks_per_s: f64,
    /// Serialized size (rmp-serde) of one tick event.
    tick_event_bytes: usize,
    stats: WorldStats,
    digest: String,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn case(name: &str, config: &Config, ticks: u64, workers: Workers<'_>) -> anyhow::Result<Case> {
    let mut walls = Vec::new();
    let mut builds = Vec::new();
    let mut last = None;
    let mut event_bytes = 0;
    for run in 1..=RUNS {
        // On stderr, so `--json` stays clean: without it the command sat silent for 16-19 s.
        eprintln!(
            "bench world: {name}, {} robots x {ticks} ticks, run {run} of {RUNS}",
            config.world.robots
        );
        let t0 = Instant::now();
        let mut world =
            World::new(config, SEED).with_context(|| format!("building the {name} world"))?;
        let mut controllers = Controllers::new(config, SEED);
        let t1 = Instant::now();
        for _ in 0..ticks {
            let event = controllers.decide_on(&world, workers);
            world.apply_on(&event, workers);
            if event_bytes == 0 {
                event_bytes = rmp_serde::to_vec(&event)?.len();
            }
        }
        let t2 = Instant::now();
        builds.push((t1 - t0).as_secs_f64());
        walls.push((t2 - t1).as_secs_f64());
        if let Some(previous) = &last {
            let (d, _): &(swarmfl_core::Digest, WorldStats) = previous;
            anyhow::ensure!(*d == world.digest(), "{name}: repeated runs differ");
        }
        last = Some((world.digest(), world.stats()));
    }
    let (digest, stats) = last.expect("at least one run");
    let wall_s = median(walls);
    Ok(Case {
        name: name.to_string(),
        robots: config.world.robots,
        arena_side_m: config.world.arena_side_m,
        ticks,
        wall_s,
        build_s: median(builds),
        robot_ticks_per_s: f64::from(config.world.robots) * ticks as f64 / wall_s,
        tick_event_bytes: event_bytes,
        stats,
        digest: digest.to_hex(),
    })
}

/// The parallel world's figures: the same swarm on one thread and on two.
#[derive(Serialize)]
struct Threads {
    one: Case,
    two: Case,
    /// Robot-ticks per second on two threads over one.
    speedup: f64,
    /// Whether both ended in the same world digest.
    same_digest: bool,
}

/// 1000 robots at the paper's density (the rule of `bench scale`) for `ticks` ticks, on one
/// thread and on two.
fn threads(ticks: u64) -> anyhow::Result<Threads> {
    let mut config =
        super::scale::scaled_config(1000, &super::scale::Workload::paper(ticks as f64 * 0.1))?;
    // A run as long as the benchmark: its held-out windows lie inside it.
    config.run.duration_s = ticks as f64 * config.run.tick_s;
    let pool = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("building the world's thread pool")
    };
    let (one_pool, two_pool) = (pool(1)?, pool(2)?);
    let one = case(
        "paper-1000-1-thread",
        &config,
        ticks,
        Workers::on(&one_pool),
    )?;
    let two = case(
        "paper-1000-2-threads",
        &config,
        ticks,
        Workers::on(&two_pool),
    )?;
    Ok(Threads {
        speedup: two.robot_ticks_per_s / one.robot_ticks_per_s,
        same_digest: one.digest == two.digest,
        one,
        two,
    })
}

/// Runs the world benchmark and prints its figures (JSON with `json`).
pub fn run(json: bool) -> anyhow::Result<()> {
    let paper = Preset::Paper.config();
    let mut big = paper.clone();
    big.world.robots *= 10;
    big.world.arena_side_m *= 10f64.sqrt();
    big.world.cylinders *= 10;
    big.world.boxes *= 10;
    let reference = Preset::Reference.config();
    let one = Workers::SEQUENTIAL;
    let cases = vec![
        case("paper-15", &paper, 50_000, one)?,
        case("paper-150-scaled", &big, 5_000, one)?,
        case("reference-15", &reference, 49_800, one)?,
    ];
    let parallel = threads(1_000)?;
    anyhow::ensure!(
        parallel.same_digest,
        "the 1000-robot world ended in {} on one thread and {} on two: the parallel world is not \
         deterministic (a bug; please report it)",
        parallel.one.digest,
        parallel.two.digest
    );
    if json {
        let all = serde_json::json!({ "cases": cases, "threads": parallel });
        println!("{}", serde_json::to_string_pretty(&all)?);
    } else {
        for c in cases.iter().chain([&parallel.one, &parallel.two]) {
            print_case(c);
        }
        println!(
            "1000 robots at the paper's density: {:.0} robot_ticks_per_s on 1 thread, {:.0} on 2: \
             {:.2}x (issue 56's acceptance: at least 1.6x); same digest on both: {}",
            parallel.one.robot_ticks_per_s,
            parallel.two.robot_ticks_per_s,
            parallel.speedup,
            parallel.same_digest
        );
    }
    Ok(())
}

/// One case's line of the table.
fn print_case(c: &Case) {
    println!(
        "{:<20} {:>4} robots {:>6.2} m {:>6} ticks: {:.3} s (median of {RUNS}), {:.0} robot_ticks_per_s; \
         build {:.3} s; tick event {} B; samples/robot/600 s {:.1} +- {:.1}; mean neighbours {:.2}; \
         discarded {}; blocked moves {}; collisions {}",
        c.name,
        c.robots,
        c.arena_side_m,
        c.ticks,
        c.wall_s,
        c.robot_ticks_per_s,
        c.build_s,
        c.tick_event_bytes,
        c.stats.samples_per_robot_per_600s,
        c.stats.samples_per_robot_per_600s_std,
        c.stats.mean_neighbours,
        c.stats.trajectories_discarded,
        c.stats.blocked_moves,
        c.stats.collisions
    );
}

//! How much trajectory data the robots collect, from the world alone
//! (controllers, physics, sensing and recording; no learning, no ledger), per behaviour, swarm
//! size and seed, beside the counts of Flow-FL's published dataset (NESTLab
//! `mrs_fl_dataset`, per robot over 5000 s; issue #38). docs/SPEC.md section 1, "Data
//! volume", explains the differences. Beside the counts it prints where the robots spend
//! their time (near a wall, in a corner) and how often a move was refused, the measures that
//! tell a swarm spread over the arena from one piled against the walls.

use std::fmt::Write as _;

use anyhow::Context;
use serde::Serialize;
use swarmfl_core::config::{Behaviour, Config};
use swarmfl_core::world::{Controllers, Forager, World};

/// Flow-FL's dataset: samples per robot over 5000 s, mean and standard deviation where
/// published, at 15 and 60 robots (issue #38).
const FLOWFL: &[(Behaviour, u32, f64, Option<f64>)] = &[
    (Behaviour::Avoidance, 15, 1415.0, Some(206.0)),
    (Behaviour::Avoidance, 60, 3610.0, Some(397.0)),
    (Behaviour::Flocking, 15, 3267.0, None),
    (Behaviour::Flocking, 60, 5552.0, None),
    (Behaviour::Foraging, 15, 2390.0, None),
    (Behaviour::Foraging, 60, 3122.0, None),
    (Behaviour::Mixed, 15, 2042.0, None),
    (Behaviour::Mixed, 60, 2914.0, None),
];

/// "Near" a wall: the robot's center within this distance of it, in metres (issue #38's 0.3 m).
pub const NEAR_M: f64 = 0.3;

/// One behaviour at one swarm size, over the seeds: what `data-volume --json` prints.
#[derive(Serialize)]
pub struct Row {
    /// The behaviour (`world.behaviour`).
    pub behaviour: &'static str,
    /// The preset the row ran under.
    pub preset: String,
    /// The swarm size.
    pub robots: u32,
    /// The seeds.
    pub seeds: Vec<u64>,
    /// Simulated seconds of each run.
    pub duration_s: f64,
    /// Per seed: the mean over robots of the samples each collected in the run.
    pub per_seed: Vec<f64>,
    /// Mean over seeds of `per_seed`.
    pub samples_per_robot: f64,
    /// Mean over seeds of the standard deviation over robots.
    pub std_over_robots: f64,
    /// `samples_per_robot` scaled to 600 s.
    pub samples_per_robot_per_600s: f64,
    /// Mean over seeds of the data-heterogeneity measure (summary `data_heterogeneity`).
    pub heterogeneity: f64,
    /// Per seed: the data-heterogeneity measure at the end of the run.
    pub heterogeneity_per_seed: Vec<f64>,
    /// Per seed: fraction of robot-ticks with the robot's center within `NEAR_M` of a wall.
    pub wall_per_seed: Vec<f64>,
    /// Per seed: fraction of robot-ticks within `NEAR_M` of two walls (a corner square).
    pub corner_per_seed: Vec<f64>,
    /// Per seed: refused moves per robot-tick (`blocked_moves` / (robots x ticks)).
    pub blocked_per_seed: Vec<f64>,
    /// Per seed: fraction of robot-ticks a robot rested in the nest (foragers; 0 without).
    pub resting_per_seed: Vec<f64>,
    /// Per seed: items delivered to the nest per robot over the run (0 without foragers).
    pub deliveries_per_seed: Vec<f64>,
    /// Per seed: the fractions of robot-ticks run as avoidance, flocking and foraging (what a
    /// mixed swarm by place, `world.mixed.assign = "place"`, spends where).
    pub behaviour_share_per_seed: Vec<[f64; 3]>,
    /// Per seed: the mean over robots of the fraction of its robot-ticks spent in its most
    /// frequent behaviour (1 when each robot keeps one behaviour, as by share; 1/3 when every
    /// robot splits its time evenly between the three).
    pub own_behaviour_per_seed: Vec<f64>,
    /// The wall and corner fractions of robots spread uniformly over the arena (obstacles
    /// ignored), for comparison.
    pub uniform_wall: f64,
    /// See `uniform_wall`.
    pub uniform_corner: f64,
    /// Flow-FL's count for this behaviour and size, scaled to `duration_s`, if published.
    pub flowfl: Option<f64>,
    /// `samples_per_robot / flowfl`.
    pub ratio: Option<f64>,
}

/// Adds a tick to each robot's count of its behaviour: avoidance, flocking, foraging.
fn count_behaviours(world: &World, ticks: &mut [[u64; 3]]) {
    let index = |b: Behaviour| match b {
        Behaviour::Flocking => 1,
        Behaviour::Foraging => 2,
        Behaviour::Avoidance | Behaviour::Mixed => 0,
    };
    for (i, robot) in ticks.iter_mut().enumerate() {
        robot[world.behaviours().map_or(0, |b| index(b.of[i]))] += 1;
    }
}

/// Reads a comma-separated list of `what` (a command-line option's name, for the message).
pub fn list<T: std::str::FromStr>(what: &str, text: &str) -> anyhow::Result<Vec<T>>
where
    T::Err: std::fmt::Display,
{
    text.split(',')
        .map(|s| {
            s.trim()
                .parse::<T>()
                .map_err(|e| anyhow::anyhow!("--{what}: cannot read `{s}`: {e}"))
        })
        .collect()
}

/// Reads a comma-separated list of `world.behaviour` values.
pub fn behaviours(text: &str) -> anyhow::Result<Vec<Behaviour>> {
    text.split(',')
        .map(|s| {
            let s = s.trim();
            Behaviour::ALL
                .into_iter()
                .find(|b| b.name() == s)
                .ok_or_else(|| {
                    anyhow::anyhow!(
                        "--behaviours: unknown behaviour `{s}`; expected one of {}",
                        Behaviour::ALL.map(Behaviour::name).join(", ")
                    )
                })
        })
        .collect()
}

/// What to measure: every behaviour at every size, each over every seed, for `duration_s`.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The behaviours, one row per size each.
    pub behaviours: Vec<Behaviour>,
    /// The swarm sizes (the arena stays as configured, as in Flow-FL).
    pub robots: Vec<u32>,
    /// The seeds.
    pub seeds: Vec<u64>,
    /// Simulated seconds of each run.
    pub duration_s: f64,
}

/// One seed's world walk: the counts a [`Row`] keeps per seed.
struct SeedMeasure {
    samples: f64,
    std: f64,
    heterogeneity: f64,
    wall: f64,
    corner: f64,
    blocked: f64,
    resting: f64,
    deliveries: f64,
    shares: [f64; 3],
    own: f64,
}

/// Walks the world of `config` with `seed` for `ticks` ticks (controllers and physics only).
fn measure_seed(config: &Config, seed: u64, ticks: u64) -> anyhow::Result<SeedMeasure> {
    let n = config.world.robots;
    let half = 0.5 * config.world.arena_side_m;
    let mut world =
        World::new(config, seed).with_context(|| format!("building the world of seed {seed}"))?;
    let mut controllers = Controllers::new(config, seed);
    let (mut near_wall, mut near_corner, mut resting) = (0u64, 0u64, 0u64);
    let mut behaviour_ticks = vec![[0u64; 3]; n as usize];
    for _ in 0..ticks {
        let event = controllers.decide(&world);
        world.apply(&event);
        count_behaviours(&world, &mut behaviour_ticks);
        if let Some(b) = world.behaviours() {
            resting += b
                .foragers
                .iter()
                .filter(|f| matches!(f, Forager::Rest { .. }))
                .count() as u64;
        }
        for p in world.poses() {
            let near_x = half - p.x.abs() < NEAR_M;
            let near_y = half - p.y.abs() < NEAR_M;
            near_wall += u64::from(near_x || near_y);
            near_corner += u64::from(near_x && near_y);
        }
    }
    let s = world.stats();
    let scale = world.time().secs() / 600.0;
    let robot_ticks = (u64::from(n) * ticks).max(1) as f64;
    let total = behaviour_ticks.iter().fold([0u64; 3], |mut a, r| {
        (0..3).for_each(|k| a[k] += r[k]);
        a
    });
    let most: u64 = behaviour_ticks
        .iter()
        .map(|r| r.iter().copied().max().unwrap_or(0))
        .sum();
    Ok(SeedMeasure {
        samples: s.samples_per_robot_per_600s * scale,
        std: s.samples_per_robot_per_600s_std * scale,
        heterogeneity: s.data_heterogeneity,
        wall: near_wall as f64 / robot_ticks,
        corner: near_corner as f64 / robot_ticks,
        blocked: s.blocked_moves as f64 / robot_ticks,
        resting: resting as f64 / robot_ticks,
        deliveries: s.foraging_deliveries as f64 / f64::from(n.max(1)),
        shares: total.map(|t| t as f64 / robot_ticks),
        own: most as f64 / robot_ticks,
    })
}

/// The mean of `v`.
fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// One row: `behaviour` at `n` robots under `base`, over the plan's seeds.
fn row(base: &Config, behaviour: Behaviour, n: u32, plan: &Plan) -> anyhow::Result<Row> {
    let mut config = base.clone();
    config.world.robots = n;
    config.world.behaviour = behaviour;
    config.run.duration_s = plan.duration_s;
    config
        .validate()
        .with_context(|| format!("behaviour {} at {n} robots", behaviour.name()))?;
    let ticks = (plan.duration_s / config.run.tick_s).round() as u64;
    let seeds = plan
        .seeds
        .iter()
        .map(|&seed| measure_seed(&config, seed, ticks))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let of = |f: fn(&SeedMeasure) -> f64| seeds.iter().map(f).collect::<Vec<f64>>();
    let per_seed = of(|m| m.samples);
    let het = of(|m| m.heterogeneity);
    let half = 0.5 * config.world.arena_side_m;
    let inner = ((half - NEAR_M).max(0.0) / half).powi(2);
    let edge = (NEAR_M / half).min(1.0);
    let samples_per_robot = mean(&per_seed);
    let flowfl = FLOWFL
        .iter()
        .find(|&&(b, r, _, _)| b == behaviour && r == n)
        .map(|&(_, _, count, _)| count * plan.duration_s / 5000.0);
    Ok(Row {
        behaviour: behaviour.name(),
        preset: base.preset.clone(),
        robots: n,
        seeds: plan.seeds.clone(),
        duration_s: plan.duration_s,
        samples_per_robot,
        std_over_robots: mean(&of(|m| m.std)),
        samples_per_robot_per_600s: samples_per_robot * 600.0 / plan.duration_s,
        heterogeneity: mean(&het),
        heterogeneity_per_seed: het,
        wall_per_seed: of(|m| m.wall),
        corner_per_seed: of(|m| m.corner),
        blocked_per_seed: of(|m| m.blocked),
        resting_per_seed: of(|m| m.resting),
        deliveries_per_seed: of(|m| m.deliveries),
        behaviour_share_per_seed: seeds.iter().map(|m| m.shares).collect(),
        own_behaviour_per_seed: of(|m| m.own),
        uniform_wall: 1.0 - inner,
        uniform_corner: edge * edge,
        flowfl,
        ratio: flowfl.map(|f| samples_per_robot / f),
        per_seed,
    })
}

/// Measures the plan: a row per behaviour and size, each behaviour under the configuration
/// `base_of` gives it.
pub fn measure(
    plan: &Plan,
    mut base_of: impl FnMut(Behaviour) -> anyhow::Result<Config>,
) -> anyhow::Result<Vec<Row>> {
    anyhow::ensure!(
        plan.duration_s.is_finite() && plan.duration_s > 0.0,
        "--duration-s: must be a positive number of seconds, got {}",
        plan.duration_s
    );
    let mut rows = Vec::new();
    for &behaviour in &plan.behaviours {
        let base = base_of(behaviour)?;
        for &n in &plan.robots {
            rows.push(row(&base, behaviour, n, plan)?);
        }
    }
    Ok(rows)
}

/// `v` with `digits` decimals, space-separated.
fn seeds_of(v: &[f64], digits: usize) -> String {
    v.iter()
        .map(|x| format!("{x:.digits$}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The lines of one row in the table: its numbers, then per seed, foragers and (mixed) the
/// behaviours' shares.
fn row_text(r: &Row, text: &mut String) {
    let _ = writeln!(
        text,
        "{:<10} {:>6} {:>10.1} {:>9.1} {:>9.1} {:>8} {:>7} {:>13.4} {:>6.3} {:>6.3} {:>7.3}",
        r.behaviour,
        r.robots,
        r.samples_per_robot,
        r.std_over_robots,
        r.samples_per_robot_per_600s,
        r.flowfl.map_or("-".to_string(), |f| format!("{f:.0}")),
        r.ratio.map_or("-".to_string(), |x| format!("{x:.2}")),
        r.heterogeneity,
        mean(&r.wall_per_seed),
        mean(&r.corner_per_seed),
        mean(&r.blocked_per_seed),
    );
    let _ = writeln!(
        text,
        "    {}, per seed: samples {} | heterogeneity {} | wall {} | corner {} | blocked {}",
        r.preset,
        seeds_of(&r.per_seed, 1),
        seeds_of(&r.heterogeneity_per_seed, 4),
        seeds_of(&r.wall_per_seed, 3),
        seeds_of(&r.corner_per_seed, 3),
        seeds_of(&r.blocked_per_seed, 3),
    );
    if r.deliveries_per_seed.iter().any(|&d| d > 0.0) || r.resting_per_seed.iter().any(|&x| x > 0.0)
    {
        let _ = writeln!(
            text,
            "    foragers: resting {} | deliveries per robot {}",
            seeds_of(&r.resting_per_seed, 3),
            seeds_of(&r.deliveries_per_seed, 1),
        );
    }
    if r.behaviour == Behaviour::Mixed.name() {
        let share = |k: usize| {
            let v: Vec<f64> = r.behaviour_share_per_seed.iter().map(|s| s[k]).collect();
            seeds_of(&v, 3)
        };
        let _ = writeln!(
            text,
            "    robot-ticks run as: avoidance {} | flocking {} | foraging {} | a robot's most frequent {}",
            share(0),
            share(1),
            share(2),
            seeds_of(&r.own_behaviour_per_seed, 3),
        );
    }
}

/// The table `data-volume` prints: a line on what ran (`presets`, the plan's length and
/// seeds), a header, each row's lines, and a line on what the wall and corner columns are.
pub fn table(rows: &[Row], presets: &str, plan: &Plan) -> String {
    let mut text = String::new();
    let _ = writeln!(
        text,
        "{presets}, {} s, seeds {:?} (samples per robot over the run; Flow-FL's dataset scaled to the same length)",
        plan.duration_s, plan.seeds
    );
    let _ = writeln!(
        text,
        "{:<10} {:>6} {:>10} {:>9} {:>9} {:>8} {:>7} {:>13} {:>6} {:>6} {:>7}",
        "behaviour",
        "robots",
        "samples",
        "+-robots",
        "per 600s",
        "Flow-FL",
        "ratio",
        "heterogeneity",
        "wall",
        "corner",
        "blocked"
    );
    for r in rows {
        row_text(r, &mut text);
    }
    if let Some(r) = rows.first() {
        let _ = writeln!(
            text,
            "wall / corner: fraction of robot-ticks with the center within {NEAR_M} m of a wall / of two walls (uniform over the arena: {:.3} / {:.3}); blocked: refused moves per robot-tick",
            r.uniform_wall, r.uniform_corner
        );
    }
    text
}

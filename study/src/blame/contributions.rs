//! Whole-run contributions: leave-one-out per robot and Shapley values over robots by
//! permutation sampling (`swarmfl contributions`).
//!
//! The game: `v(S)` is the outcome when only the robots of `S` submit (the others are
//! `learn.withheld`), re-simulated exactly. A robot's leave-one-out is `v(N) - v(N - {i})`,
//! its Shapley value the mean over sampled orders of `v(P + {i}) - v(P)`, `P` the robots
//! before it; both are positive when the robot makes the outcome larger (for a loss: worse).
//! The values sum to `v(N) - v({})` for every sample (efficiency). Each coalition is run once.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::world::Parent;
use super::{outcome_expr, At};
use crate::progress::Watch;
use crate::run::process_cpu_s;

/// One robot's contributions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contribution {
    /// Its id.
    pub robot: u32,
    /// Whether it is Byzantine (the log's header).
    pub byzantine: bool,
    /// Leave-one-out: the outcome minus the outcome without its submissions.
    pub leave_one_out: f64,
    /// Its Shapley value (`None` with no samples).
    pub shapley: Option<f64>,
    /// The standard error of the Shapley estimate over the sampled orders (`None` below 2).
    pub shapley_se: Option<f64>,
}

/// A run's contributions, by robot id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contributions {
    /// The log.
    pub log: String,
    /// The outcome expression.
    pub expr: String,
    /// Its value in the run, `v(N)`.
    pub outcome: f64,
    /// Its value when no robot submits, `v({})` (`None` with no samples).
    pub nobody: Option<f64>,
    /// The block it is read at and its time, s.
    pub block: u64,
    /// That block's time, s.
    pub time_s: f64,
    /// Sampled orders.
    pub samples: u32,
    /// The seed of the orders.
    pub seed: u64,
    /// The robots, by id.
    pub robots: Vec<Contribution>,
    /// Counterfactual runs made (each coalition once).
    pub counterfactuals: u64,
    /// Wall seconds they took.
    pub wall_s: f64,
    /// CPU seconds of this process meanwhile.
    pub cpu_s: f64,
}

/// The game's values, each coalition run once (keyed by the withheld robots that matter).
struct Game<'a> {
    parent: &'a Parent,
    values: BTreeMap<Vec<u32>, f64>,
    runs: u64,
    watch: &'a dyn Watch,
}

impl Game<'_> {
    /// `v` of the coalition whose complement is `withheld`.
    fn value(&mut self, withheld: &[u32]) -> anyhow::Result<f64> {
        // Robots that never report change nothing: leave them out of the key and the run.
        let mut key: Vec<u32> = withheld
            .iter()
            .copied()
            .filter(|&r| self.parent.robots[r as usize].first_learn.is_some())
            .collect();
        key.sort_unstable();
        if key.is_empty() {
            return Ok(self.parent.outcome);
        }
        if let Some(&v) = self.values.get(&key) {
            return Ok(v);
        }
        let v = self.parent.counterfactual(&key, &[])?;
        self.runs += 1;
        self.watch
            .say(&format!("run {}: without {key:?}: {v}", self.runs));
        self.values.insert(key, v);
        Ok(v)
    }
}

/// A splitmix64 stream: the orders' draws (not the simulation's state).
struct Orders(u64);

impl Orders {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// A uniform order of `0..n` (Fisher-Yates).
    fn order(&mut self, n: u32) -> Vec<u32> {
        let mut order: Vec<u32> = (0..n).collect();
        for i in (1..order.len()).rev() {
            let j = (self.next() % (i as u64 + 1)) as usize;
            order.swap(i, j);
        }
        order
    }
}

/// Leave-one-out of every robot and, with `samples > 0`, Shapley values from `samples` orders
/// drawn with `seed`, of the outcome `outcome` read `at` in the run at `log`.
pub fn contributions(
    log: &Path,
    outcome: &str,
    at: &At,
    samples: u32,
    seed: u64,
    watch: &dyn Watch,
) -> anyhow::Result<Contributions> {
    let expr = outcome_expr(outcome)?;
    let parent = Parent::load(log, &expr, at)?;
    let n = parent.config.world.robots;
    let started = Instant::now();
    let cpu0 = process_cpu_s();
    let mut game = Game {
        parent: &parent,
        values: BTreeMap::new(),
        runs: 0,
        watch,
    };
    let mut loo = Vec::with_capacity(n as usize);
    for r in 0..n {
        loo.push(parent.outcome - game.value(&[r])?);
    }
    let mut marginals = vec![Vec::with_capacity(samples as usize); n as usize];
    let mut orders = Orders(seed);
    let everyone: Vec<u32> = (0..n).collect();
    let nobody = if samples > 0 {
        Some(game.value(&everyone)?)
    } else {
        None
    };
    for _ in 0..samples {
        let order = orders.order(n);
        // Walk the order: the coalition grows from nobody to everyone.
        let mut withheld = everyone.clone();
        let mut before = game.value(&withheld)?;
        for &r in &order {
            withheld.retain(|&w| w != r);
            let after = game.value(&withheld)?;
            marginals[r as usize].push(after - before);
            before = after;
        }
    }
    let robots = (0..n)
        .map(|r| {
            let m = &marginals[r as usize];
            let (mean, se) = mean_and_se(m);
            Contribution {
                robot: r,
                byzantine: parent.byzantine[r as usize],
                leave_one_out: loo[r as usize],
                shapley: mean,
                shapley_se: se,
            }
        })
        .collect();
    Ok(Contributions {
        log: parent.name.clone(),
        expr: outcome.to_string(),
        outcome: parent.outcome,
        nobody,
        block: parent.block,
        time_s: parent.block_s,
        samples,
        seed,
        robots,
        counterfactuals: game.runs,
        wall_s: started.elapsed().as_secs_f64(),
        cpu_s: process_cpu_s() - cpu0,
    })
}

/// The mean of `xs` and its standard error (sample standard deviation over sqrt(n)), summed
/// in order.
fn mean_and_se(xs: &[f64]) -> (Option<f64>, Option<f64>) {
    if xs.is_empty() {
        return (None, None);
    }
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    if xs.len() < 2 {
        return (Some(mean), None);
    }
    let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (Some(mean), Some((var / n).sqrt()))
}

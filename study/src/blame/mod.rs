//! Who caused it: exact counterfactual attribution by re-simulation (`swarmfl blame`,
//! `swarmfl contributions`).
//!
//! An outcome (an expression over `bisect`'s identifiers, the held-out loss by default) is read
//! at the swarm's canonical head at a stop: the end of the tick that sealed the first block
//! where `--until` holds, or block `--block N`, or the end of the run. A robot's influence is
//! the parent's outcome minus the outcome of the counterfactual in which it never submits
//! (`learn.withheld = [k]`): the same seed and configuration re-simulated from genesis to the
//! stop, which is bit for bit the run `swarmfl run --set learn.withheld=[k]` makes (its records
//! equal the parent's up to the robot's first learning report, which is checked). A Byzantine
//! robot's influence "as if honest" uses `byzantine.as_honest = [k]` instead.
//!
//! Why re-simulate and not re-fold the recorded world: the robots' motion and data do not
//! depend on models or tokens (ARCHITECTURE.md, "Counterfactuals"), but local training is
//! about 90 % of a run and every training after the first withheld submission starts from
//! another model, so only the world's 10 % could be saved; the counterfactual runs the plain
//! driver, which keeps it exact by construction.

mod contributions;
mod world;

use std::path::Path;
use std::time::Instant;

use anyhow::bail;
use serde::{Deserialize, Serialize};
use swarmfl_core::inspect::Expr;

pub use contributions::{contributions, Contribution, Contributions};

use crate::progress::Watch;
use crate::run::process_cpu_s;
use world::Parent;

/// The outcome expression when none is given: the held-out loss.
pub const DEFAULT_OUTCOME: &str = "heldout_loss";

/// Where the outcome is read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum At {
    /// At the end of the run.
    End,
    /// At block `N` of the parent's final canonical chain (the end of its sealing tick).
    Block(u64),
    /// At the first block of the parent's final canonical chain where the condition holds.
    Until(String),
}

impl At {
    /// From the flags `--until` and `--block` (neither: the end).
    pub fn from_flags(until: Option<String>, block: Option<u64>) -> At {
        match (until, block) {
            (Some(cond), _) => At::Until(cond),
            (None, Some(n)) => At::Block(n),
            (None, None) => At::End,
        }
    }
}

/// What to blame: the log, the outcome and where it is read, which robots.
#[derive(Clone, Debug)]
pub struct BlameRequest {
    /// The expression whose value is the outcome ([`DEFAULT_OUTCOME`] by default).
    pub outcome: String,
    /// Where it is read.
    pub at: At,
    /// The robots to blame (`None`: every robot).
    pub robots: Option<Vec<u32>>,
    /// Also the "as if honest" counterfactual of each Byzantine robot.
    pub as_honest: bool,
}

impl Default for BlameRequest {
    fn default() -> Self {
        BlameRequest {
            outcome: DEFAULT_OUTCOME.to_string(),
            at: At::End,
            robots: None,
            as_honest: true,
        }
    }
}

/// One robot's blame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotBlame {
    /// Its id.
    pub robot: u32,
    /// The outcome minus the outcome without its submissions (positive: it made the outcome
    /// larger).
    pub influence: f64,
    /// Whether it is Byzantine (the log's header).
    pub byzantine: bool,
    /// The outcome without its submissions.
    pub without: f64,
    /// Byzantine robots: the outcome minus the outcome had it learned honestly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub influence_as_honest: Option<f64>,
    /// Its submissions (trained or forged) before the stop.
    pub submissions: u64,
    /// The rounds closed by the stop that counted its model as accepted: where its influence
    /// entered the shared model.
    pub accepted_rounds: Vec<u64>,
    /// The rounds that counted its model as an outlier (its stake kept).
    pub outlier_rounds: Vec<u64>,
    /// When its first learning report came (s): where its counterfactual leaves the run.
    pub first_report_s: Option<f64>,
}

/// A run's blame: the outcome and every robot's influence, most influential first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlameReport {
    /// The log.
    pub log: String,
    /// The outcome expression.
    pub expr: String,
    /// Its value in the run.
    pub outcome: f64,
    /// The block it is read at (the canonical head at the stop) and its time, s.
    pub block: u64,
    /// That block's time, s.
    pub time_s: f64,
    /// The robots, largest influence first (for a loss: the most harmful; ties by id).
    pub robots: Vec<RobotBlame>,
    /// Counterfactual runs made.
    pub counterfactuals: u64,
    /// Wall seconds the counterfactuals took.
    pub wall_s: f64,
    /// CPU seconds of this process meanwhile (every thread).
    pub cpu_s: f64,
}

/// Parses the outcome expression, naming the flag.
fn outcome_expr(src: &str) -> anyhow::Result<Expr> {
    Expr::parse(src).map_err(|e| anyhow::anyhow!("the outcome {src:?}: {e}"))
}

/// Checks that every robot asked for is in the swarm of `robots` robots.
fn check_robots(asked: &Option<Vec<u32>>, robots: u32, name: &str) -> anyhow::Result<Vec<u32>> {
    let Some(asked) = asked else {
        return Ok((0..robots).collect());
    };
    if let Some(bad) = asked.iter().find(|&&r| r >= robots) {
        bail!(
            "there is no robot {bad} in {name}: its swarm has robots 0 to {}; give --robot \
             with ids in that range",
            robots.saturating_sub(1)
        );
    }
    let mut ids = asked.clone();
    ids.sort_unstable();
    ids.dedup();
    Ok(ids)
}

/// Blames the run at `log` as `request` asks: one counterfactual per robot (and one more per
/// Byzantine robot as if honest), each said through `watch`.
pub fn blame(log: &Path, request: &BlameRequest, watch: &dyn Watch) -> anyhow::Result<BlameReport> {
    let expr = outcome_expr(&request.outcome)?;
    let parent = Parent::load(log, &expr, &request.at)?;
    let ids = check_robots(&request.robots, parent.config.world.robots, &parent.name)?;
    watch.say(&format!(
        "outcome {} = {} at block {} (t = {} s); {} counterfactuals",
        request.outcome,
        parent.outcome,
        parent.block,
        parent.block_s,
        ids.len()
            + ids
                .iter()
                .filter(|&&r| request.as_honest && parent.byzantine[r as usize])
                .count()
    ));
    let started = Instant::now();
    let cpu0 = process_cpu_s();
    let mut robots = Vec::with_capacity(ids.len());
    let mut made = 0;
    for &r in &ids {
        let facts = &parent.robots[r as usize];
        let byzantine = parent.byzantine[r as usize];
        // A robot that never reported leaves every record as it is: no run needed.
        let without = if facts.first_learn.is_none() {
            parent.outcome
        } else {
            made += 1;
            parent.counterfactual(&[r], &[])?
        };
        let influence_as_honest = if byzantine && request.as_honest && facts.first_learn.is_some() {
            made += 1;
            Some(parent.outcome - parent.counterfactual(&[], &[r])?)
        } else {
            None
        };
        watch.say(&format!(
            "robot {r}{}: without it {without} (influence {})",
            if byzantine { " (Byzantine)" } else { "" },
            parent.outcome - without
        ));
        robots.push(RobotBlame {
            robot: r,
            influence: parent.outcome - without,
            byzantine,
            without,
            influence_as_honest,
            submissions: facts.submissions,
            accepted_rounds: facts.accepted_rounds.clone(),
            outlier_rounds: facts.outlier_rounds.clone(),
            first_report_s: facts.first_learn.map(|t| t.secs()),
        });
    }
    robots.sort_by(|a, b| {
        b.influence
            .total_cmp(&a.influence)
            .then(a.robot.cmp(&b.robot))
    });
    Ok(BlameReport {
        log: parent.name.clone(),
        expr: request.outcome.clone(),
        outcome: parent.outcome,
        block: parent.block,
        time_s: parent.block_s,
        robots,
        counterfactuals: made,
        wall_s: started.elapsed().as_secs_f64(),
        cpu_s: process_cpu_s() - cpu0,
    })
}

/// Reads a blame report written by `swarmfl blame --json` (for the viewer), naming the file.
pub fn read_report(path: &Path) -> anyhow::Result<BlameReport> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow::anyhow!("cannot read the blame report {}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| {
        anyhow::anyhow!(
            "{} is not a blame report ({e}); make one with `swarmfl blame LOG --json > {}`",
            path.display(),
            path.display()
        )
    })
}

#[cfg(test)]
mod tests;

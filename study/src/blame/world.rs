//! The parent run and its counterfactuals: folding a log, or a simulation as it runs, up to
//! the outcome's time, and reading the outcome there.

use std::path::Path;

use anyhow::{bail, Context};
use swarmfl_core::config::{Aggregation, Config};
use swarmfl_core::contract::Verdict;
use swarmfl_core::event::{Event, Record};
use swarmfl_core::inspect::{self, expr::Expr, Indexer};
use swarmfl_core::log::LogReader;
use swarmfl_core::metrics::LearnAction;
use swarmfl_core::sim::Sim;
use swarmfl_core::types::SimTime;

use super::At;

/// Where the outcome is read: the swarm's canonical head at the end of the tick ending at
/// `at` (`None`: the end of the run).
#[derive(Clone, Copy, Debug)]
pub(super) struct Stop {
    pub(super) at: Option<SimTime>,
}

impl Stop {
    /// Whether `record` lies past the stop: after its time, or the next tick's world step.
    fn past(self, record: &Record) -> bool {
        let Some(at) = self.at else { return false };
        let t = record.time();
        t > at
            || (t == at
                && matches!(
                    record,
                    Record::Event {
                        event: Event::Tick(_),
                        ..
                    }
                ))
    }
}

/// What the parent run says about each robot up to the stop.
#[derive(Clone, Debug, Default)]
pub(super) struct RobotFacts {
    /// Time of its first learning report (where its counterfactual leaves the parent).
    pub(super) first_learn: Option<SimTime>,
    /// Its submissions (trained or forged) by the stop.
    pub(super) submissions: u64,
    /// Rounds closed on the canonical chain by the stop that counted its model as accepted.
    pub(super) accepted_rounds: Vec<u64>,
    /// Rounds that counted its model as an outlier.
    pub(super) outlier_rounds: Vec<u64>,
}

/// The parent log, read once: its configuration, the stop, its outcome and what each robot did.
pub(super) struct Parent {
    pub(super) name: String,
    pub(super) config: Config,
    pub(super) seed: u64,
    pub(super) byzantine: Vec<bool>,
    pub(super) stop: Stop,
    /// Height of the block the outcome is read at, and its time (s).
    pub(super) block: u64,
    pub(super) block_s: f64,
    pub(super) outcome: f64,
    expr: Expr,
    pub(super) robots: Vec<RobotFacts>,
    /// The parent's checkpoints up to the stop, to check a counterfactual's common prefix.
    checkpoints: Vec<Record>,
}

/// Refuses what blame cannot re-simulate exactly, naming the fix.
fn check_header(path: &Path, name: &str) -> anyhow::Result<(Config, u64)> {
    let reader = LogReader::open(path).with_context(|| format!("cannot open {name}"))?;
    let header = reader.header();
    if !header.plugins.is_empty() {
        bail!(
            "{name} was made with plug-ins ({}); blame's counterfactuals re-simulate the \
             run and cannot be offered plug-ins yet: blame a run of a built-in \
             byzantine.kind and contract.rule (swarmfl run --set byzantine.kind=...)",
            header
                .plugins
                .iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if header.parent.is_some() {
        bail!(
            "{name} is a fork (its configuration changes mid-run); blame its parent, or \
             re-run the fork's configuration as a run of its own (swarmfl run --set ...)"
        );
    }
    let config = swarmfl_core::replay::header_config(&reader, name)?;
    if config.learn.aggregation != Aggregation::Chain {
        bail!(
            "{name}: a learn.aggregation = {} run has no blocks to read an outcome at; blame \
             needs learn.aggregation = chain",
            config.learn.aggregation.name()
        );
    }
    Ok((config, header.seed))
}

impl Parent {
    /// Reads the parent log at `path`: refuses a truncated log, a plug-in run, a fork and a
    /// baseline; finds the stop `at` names and folds the log to it.
    pub(super) fn load(path: &Path, expr: &Expr, at: &At) -> anyhow::Result<Parent> {
        let name = path.display().to_string();
        let (config, seed) = check_header(path, &name)?;
        let index = inspect::index_run(path, None)?;
        if let Some(why) = &index.truncated {
            bail!(
                "{name} is cut short ({why}); blame re-simulates whole runs: re-run it \
                 (swarmfl run --seed {seed} with its configuration: swarmfl config {name}) and \
                 blame the new log"
            );
        }
        let tick_ms = (config.run.tick_s * 1000.0).round() as u64;
        let end_ms = config.ticks() * tick_ms;
        let height = match at {
            At::End => None,
            At::Block(n) => {
                let last = index.last_height();
                if *n > last {
                    bail!(
                        "{name}: there is no block {n} on the final canonical chain; its last \
                         block is at height {last}: give --block 1 to {last}"
                    );
                }
                Some(*n)
            }
            At::Until(src) => Some(until_height(&index, src, &name)?),
        };
        let at_ms = height
            .map(|h| index.chain[h as usize].time.0.div_ceil(tick_ms) * tick_ms)
            .filter(|&ms| ms < end_ms);
        let stop = Stop {
            at: at_ms.map(SimTime),
        };
        let robots = config.world.robots as usize;
        let mut facts = vec![RobotFacts::default(); robots];
        let mut checkpoints = Vec::new();
        let mut reader = LogReader::open(path)?;
        let mut indexer = Indexer::start(&reader, &name, None)?;
        let mut records = std::iter::from_fn(|| reader.next_record().transpose());
        let mut note = |record: &Record| {
            note_learning(&mut facts, record);
            if matches!(record, Record::Checkpoint(_)) {
                checkpoints.push(record.clone());
            }
            Ok(())
        };
        fold_to_stop(
            &mut indexer,
            &mut records.by_ref().map(|r| r.map_err(anyhow::Error::from)),
            stop,
            &mut note,
        )?;
        let (outcome, block, block_s) = read_outcome(&mut indexer, stop, expr, &name)?;
        note_rounds(&mut facts, &mut indexer, stop)?;
        Ok(Parent {
            byzantine: swarmfl_core::byzantine::byzantine_robots(&config, seed),
            name,
            config,
            seed,
            stop,
            block,
            block_s,
            outcome,
            expr: expr.clone(),
            robots: facts,
            checkpoints,
        })
    }

    /// The outcome of the parent's configuration with `withheld` robots submitting nothing and
    /// `as_honest` Byzantine robots learning honestly, re-simulated from genesis to the stop
    /// (its records up to the first robot changed's first learning report are checked against
    /// the parent's checkpoints).
    pub(super) fn counterfactual(
        &self,
        withheld: &[u32],
        as_honest: &[u32],
    ) -> anyhow::Result<f64> {
        Ok(self.counterfactual_run(withheld, as_honest)?.0)
    }

    /// [`Parent::counterfactual`] and the last checkpoint the re-simulation made (its state's
    /// digest: what the exactness test compares with a fresh run's).
    pub(super) fn counterfactual_run(
        &self,
        withheld: &[u32],
        as_honest: &[u32],
    ) -> anyhow::Result<(f64, Option<Record>)> {
        let mut config = self.config.clone();
        config.learn.withheld = withheld.to_vec();
        config.byzantine.as_honest = as_honest.to_vec();
        config.validate()?;
        let name = format!(
            "{} without {withheld:?}, {as_honest:?} as honest",
            self.name
        );
        let diverges = withheld
            .iter()
            .chain(as_honest)
            .filter_map(|&r| self.robots.get(r as usize).and_then(|f| f.first_learn))
            .min();
        let mut indexer = Indexer::for_config(config.clone(), self.seed, &name, None)?;
        let sim = Sim::new(config, self.seed)?;
        let mut parent = self.checkpoints.iter();
        let mut last = None;
        let mut check = |record: &Record| {
            if matches!(record, Record::Checkpoint(_)) {
                last = Some(record.clone());
            }
            if !matches!(record, Record::Checkpoint(_))
                || diverges.is_none_or(|t| record.time() >= t)
            {
                return Ok(());
            }
            if parent.next() != Some(record) {
                bail!(
                    "{}: re-simulating it under this build gives another checkpoint at t = {} \
                     (before any change); it was made by another build: re-run it with this one \
                     (swarmfl run --seed {}) and blame the new log",
                    self.name,
                    record.time(),
                    self.seed
                );
            }
            Ok(())
        };
        fold_to_stop(&mut indexer, &mut sim.map(Ok), self.stop, &mut check)?;
        let outcome = read_outcome(&mut indexer, self.stop, &self.expr, &name)?.0;
        Ok((outcome, last))
    }
}

/// The first block of the final canonical chain where the condition `src` holds.
fn until_height(index: &inspect::RunIndex, src: &str, name: &str) -> anyhow::Result<u64> {
    let predicate = Expr::parse(src).map_err(|e| anyhow::anyhow!("--until {src:?}: {e}"))?;
    let values = index.values();
    match inspect::bisect(&values, &predicate, false)? {
        Some(hit) => Ok(hit.height),
        None => {
            let last = index.last_height();
            let seen = predicate
                .leaves(&values.at(last))
                .iter()
                .map(|(k, v)| format!("{k} = {v}"))
                .collect::<Vec<_>>()
                .join(", ");
            bail!(
                "{name}: the condition `{src}` never holds on its {} blocks (at the last, \
                 height {last}: {seen}); give a condition that holds (swarmfl bisect {name} --until \
                 '{src}' says why), --block N, or leave --until out for \
                 the end of the run",
                last + 1
            )
        }
    }
}

/// Feeds `records` to `indexer` up to `stop`, each through `each` first.
fn fold_to_stop(
    indexer: &mut Indexer,
    records: &mut dyn Iterator<Item = anyhow::Result<Record>>,
    stop: Stop,
    each: &mut dyn FnMut(&Record) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    for record in records {
        let record = record?;
        if stop.past(&record) {
            break;
        }
        each(&record)?;
        let index = indexer.records();
        indexer.feed(index, &record)?;
    }
    Ok(())
}

/// The outcome `expr` at the canonical head of the fold so far: (value, height, time s).
fn read_outcome(
    indexer: &mut Indexer,
    stop: Stop,
    expr: &Expr,
    name: &str,
) -> anyhow::Result<(f64, u64, f64)> {
    let cut = stop.at.map(|t| format!("stopped at t = {t}"));
    let index = indexer.index(cut)?;
    let values = index.values();
    let h = index.last_height();
    let value = expr
        .eval(&values.at(h))
        .map_err(|e| anyhow::anyhow!("{name}: cannot evaluate the outcome at block {h}: {e}"))?;
    Ok((value, h, index.chain[h as usize].time.secs()))
}

/// Notes a robot's first learning report and its submissions.
fn note_learning(facts: &mut [RobotFacts], record: &Record) {
    if let Record::Event {
        time,
        event: Event::Learn(report),
    } = record
    {
        if let Some(f) = facts.get_mut(report.robot as usize) {
            f.first_learn.get_or_insert(*time);
            if matches!(
                report.action,
                LearnAction::Trained { .. } | LearnAction::Forged { .. }
            ) {
                f.submissions += 1;
            }
        }
    }
}

/// Notes the rounds closed on the canonical chain that counted each robot's model.
fn note_rounds(facts: &mut [RobotFacts], indexer: &mut Indexer, stop: Stop) -> anyhow::Result<()> {
    let index = indexer.index(stop.at.map(|t| format!("stopped at t = {t}")))?;
    for (_, summary) in index.closed_rounds() {
        for s in &summary.submissions {
            if let Some(f) = facts.get_mut(s.sender as usize) {
                match s.verdict {
                    Verdict::Accepted => f.accepted_rounds.push(summary.round),
                    Verdict::Outlier => f.outlier_rounds.push(summary.round),
                }
            }
        }
    }
    Ok(())
}

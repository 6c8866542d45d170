//! Bytes sent and stored per node over time (issue 32: what one node carries as the swarm
//! grows), read from a log: one fold of the index ([`Indexer`]) that notes, at every period's
//! end, the same quantities that `summary.json`'s `aggregation` section reports at the end.
//!
//! Definitions, per robot, the same as [`AggregationSummary`]'s:
//! - *sent*: the bytes it put on the radio for aggregation so far, lost messages included.
//!   `chain`: the ledger gossip messages it sent (blocks and transactions, each item at its
//!   encoded size, as the ledger counts them); `gossip`: its stigmergy messages; `central`: its
//!   uploads.
//! - *stored*: the bytes it holds for aggregation now. `chain`: every block its node holds,
//!   side branches included; `gossip`: the entries of its replica; `central`: its own model.
//!
//! The row at time `t` holds every record before `t` (as the ledger's chain-size samples,
//! [`crate::ledger::ChainBytesSample`]; the first row, at 0, is genesis); the last row, at the
//! run's end, holds every record, so its means are the summary's `bytes_sent_per_robot_mean`
//! and `bytes_stored_per_robot_mean`, computed the same way, bit for bit. The ledger counts a chain run's gossip bytes for the
//! whole swarm only; a node's share is its `Send` events' items, sized in the state the
//! message left from (the reducer sizes them there too), and their sum is checked against the
//! ledger's total at the end.

use std::path::Path;

use super::error::InspectError;
use super::index::Indexer;
use super::tables::{Column, Table};
use crate::aggregation::summary::per_robot_mean;
use crate::aggregation::AggregationSummary;
use crate::config::{Aggregation, Config};
use crate::event::{Event, Record};
use crate::ledger::LedgerEvent;
use crate::log::LogReader;
use crate::replay::ReplayError;
use crate::state::State;
use crate::types::SimTime;

/// The longest period accepted, in simulated ms (a million seconds, past any run).
pub const MAX_PERIOD_MS: u64 = 1_000_000_000;

/// Bytes over the swarm's robots at one moment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// Mean over robots (the summary's definition).
    pub mean: f64,
    /// The fewest bytes of one robot.
    pub min: u64,
    /// The median robot (nearest rank: the lower of the two middle ones).
    pub median: u64,
    /// The most bytes of one robot.
    pub max: u64,
}

impl Spread {
    /// The spread of `bytes` (one value per robot, robot order) with its `mean` as given.
    fn of(bytes: &[u64], mean: f64) -> Spread {
        let mut sorted = bytes.to_vec();
        sorted.sort_unstable();
        Spread {
            mean,
            min: sorted.first().copied().unwrap_or(0),
            median: sorted
                .get(sorted.len().saturating_sub(1) / 2)
                .copied()
                .unwrap_or(0),
            max: sorted.last().copied().unwrap_or(0),
        }
    }
}

/// One moment of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct TrafficRow {
    /// Simulated time.
    pub time: SimTime,
    /// Bytes sent so far, per robot.
    pub sent: Spread,
    /// Bytes stored now, per robot.
    pub stored: Spread,
}

/// A run's bytes per robot over time.
#[derive(Clone, Debug)]
pub struct Traffic {
    /// The log's name.
    pub path: String,
    /// The run's configuration (at its end).
    pub config: Config,
    /// The run's seed.
    pub seed: u64,
    /// Genesis (time 0), one row every period, then the end of the run (its last row).
    pub rows: Vec<TrafficRow>,
}

impl Traffic {
    /// The aggregation as the e6 study names it: the chain's round protocol (`rounds`,
    /// `buffered`), or the baseline (`gossip`, `central`).
    pub fn mode(&self) -> &'static str {
        match self.config.learn.aggregation {
            Aggregation::Chain => self.config.contract.protocol.name(),
            other => other.name(),
        }
    }

    /// The rows as columns, bytes per robot: `time_s`, then `sent_` and `stored_` `mean`,
    /// `min`, `median`, `max`.
    pub fn table(&self) -> Table {
        let f = |g: fn(&TrafficRow) -> f64| Column::F64(self.rows.iter().map(g).collect());
        let u = |g: fn(&TrafficRow) -> u64| Column::U64(self.rows.iter().map(g).collect());
        Table {
            columns: vec![
                ("time_s", f(|r| r.time.secs())),
                ("sent_mean", f(|r| r.sent.mean)),
                ("sent_min", u(|r| r.sent.min)),
                ("sent_median", u(|r| r.sent.median)),
                ("sent_max", u(|r| r.sent.max)),
                ("stored_mean", f(|r| r.stored.mean)),
                ("stored_min", u(|r| r.stored.min)),
                ("stored_median", u(|r| r.stored.median)),
                ("stored_max", u(|r| r.stored.max)),
            ],
        }
    }

    /// Whether the last row's means are `summary`'s end values, bit for bit.
    pub fn ends_at(&self, summary: &AggregationSummary) -> bool {
        self.rows.last().is_some_and(|r| {
            r.sent.mean.to_bits() == summary.bytes_sent_per_robot_mean.to_bits()
                && r.stored.mean.to_bits() == summary.bytes_stored_per_robot_mean.to_bits()
        })
    }
}

/// Bytes sent and stored per robot at genesis, every `every` of simulated time and at the end
/// of the complete log at `path`, from one fold that checks every checkpoint. A truncated or
/// corrupt log is an error (the log's own, naming the file and what to do): its end values
/// would not be the run's.
pub fn traffic(path: &Path, every: SimTime) -> Result<Traffic, InspectError> {
    let name = path.display().to_string();
    if every.0 == 0 || every.0 > MAX_PERIOD_MS {
        return Err(InspectError::Period {
            period: every,
            max: SimTime(MAX_PERIOD_MS),
        });
    }
    let mut reader = LogReader::open(path).map_err(ReplayError::from)?;
    let mut indexer = Indexer::start(&reader, &name, None)?;
    let mut sent = Sent::new(indexer.config().world.robots);
    let mut rows = vec![row(SimTime(0), indexer.config(), indexer.state(), &sent)];
    let mut next = every;
    while let Some(record) = reader.next_record().map_err(ReplayError::from)? {
        // Bounded by the run's length over the period: records come in time order.
        while record.time() >= next {
            rows.push(row(next, indexer.config(), indexer.state(), &sent));
            next = SimTime(next.0 + every.0);
        }
        sent.note(indexer.state(), &record);
        indexer.feed(reader.index() - 1, &record)?;
    }
    let state = indexer.state();
    let total = state.ledger.stats().gossip_bytes;
    if sent.total() != total {
        return Err(InspectError::Inconsistent {
            path: name,
            message: format!(
                "the nodes' gossip messages add up to {} bytes, the ledger counted {total}",
                sent.total()
            ),
        });
    }
    let end = state.world.time();
    if rows.last().is_some_and(|r: &TrafficRow| r.time == end) {
        rows.pop();
    }
    rows.push(row(end, indexer.config(), state, &sent));
    let config = indexer.config().clone();
    let seed = reader.header().seed;
    Ok(Traffic {
        path: name,
        config,
        seed,
        rows,
    })
}

/// The ledger gossip bytes each node sent so far (a chain run's; the baselines count their own
/// per robot in the reduced state).
struct Sent {
    bytes: Vec<u64>,
}

impl Sent {
    fn new(robots: u32) -> Sent {
        Sent {
            bytes: vec![0; robots as usize],
        }
    }

    /// Counts a `Send` record's bytes for its sender, sized in `state`, the state it is folded
    /// into next. A sender out of the swarm is the fold's to refuse.
    fn note(&mut self, state: &State, record: &Record) {
        if let Record::Event {
            event: Event::Ledger(LedgerEvent::Send { from, items, .. }),
            ..
        } = record
        {
            if let Some(slot) = self.bytes.get_mut(*from as usize) {
                *slot += items
                    .iter()
                    .map(|i| state.ledger.item_bytes(i))
                    .sum::<u64>();
            }
        }
    }

    fn total(&self) -> u64 {
        self.bytes.iter().sum()
    }
}

/// The row at `time` of `state`, each mean computed as the summary computes it
/// (`aggregation/summary.rs`; the ledger's stored mean in `ledger/metrics.rs`).
fn row(time: SimTime, config: &Config, state: &State, sent: &Sent) -> TrafficRow {
    let robots = config.world.robots;
    match config.learn.aggregation {
        Aggregation::Chain => {
            let stored: Vec<u64> = (0..robots)
                .map(|r| state.ledger.node(r).stored_bytes())
                .collect();
            TrafficRow {
                time,
                sent: Spread::of(&sent.bytes, sent.total() as f64 / f64::from(robots.max(1))),
                stored: Spread::of(
                    &stored,
                    stored.iter().sum::<u64>() as f64 / stored.len().max(1) as f64,
                ),
            }
        }
        Aggregation::Gossip | Aggregation::Central | Aggregation::Matched => {
            let a = &state.aggregation;
            let stored = a.stored_bytes();
            TrafficRow {
                time,
                sent: Spread::of(&a.bytes_sent, per_robot_mean(&a.bytes_sent)),
                stored: Spread::of(&stored, per_robot_mean(&stored)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;
    use crate::config::{Preset, RoundProtocol};
    use crate::log::{Header, LogWriter};
    use crate::sim::Sim;
    use crate::summary::RunSummary;

    /// A short smoke run (200 s, seed 4) under `aggregation` and `protocol`, written to a
    /// temporary log; with the summary of its final state, as `swarmfl run` makes it.
    fn short_run(aggregation: Aggregation, protocol: RoundProtocol) -> (PathBuf, RunSummary) {
        let mut config = Preset::Smoke.config();
        config.run.duration_s = 200.0;
        config.learn.aggregation = aggregation;
        config.contract.protocol = protocol;
        config.validate().unwrap();
        let dir = std::env::temp_dir().join(format!(
            "swarmfl-traffic-{}-{}-{}",
            std::process::id(),
            aggregation.name(),
            protocol.name()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.swlog");
        let header = Header::new(4, config.to_toml());
        let mut writer = LogWriter::create(&path, &header).unwrap();
        let mut sim = Sim::new(config, 4).unwrap();
        for record in sim.by_ref() {
            writer.append(&record).unwrap();
        }
        let records = writer.records();
        let (footer, _) = writer.finish().unwrap();
        let summary = RunSummary::new(sim.config(), 4, sim.state(), records, footer.final_hash);
        (path, summary)
    }

    /// Rows every 30 s of a 200 s run end at the summary's values, bit for bit, and grow.
    fn check(aggregation: Aggregation, protocol: RoundProtocol) {
        let (path, summary) = short_run(aggregation, protocol);
        let t = traffic(&path, SimTime(30_000)).unwrap();
        let times: Vec<u64> = t.rows.iter().map(|r| r.time.0).collect();
        let end = (summary.sim_time_s * 1000.0).round() as u64;
        let mut expect: Vec<u64> = (0..).map(|k| k * 30_000).take_while(|&t| t < end).collect();
        expect.push(end);
        assert_eq!(times, expect, "{}", t.mode());
        let last = t.rows.last().unwrap();
        let a = &summary.aggregation;
        assert_eq!(
            (last.sent.mean.to_bits(), last.stored.mean.to_bits()),
            (
                a.bytes_sent_per_robot_mean.to_bits(),
                a.bytes_stored_per_robot_mean.to_bits()
            ),
            "{}: the last row is the summary's end values",
            t.mode()
        );
        assert!(t.ends_at(a));
        assert!(
            last.sent.mean > 0.0 && last.stored.mean > 0.0,
            "{}",
            t.mode()
        );
        for pair in t.rows.windows(2) {
            assert!(pair[0].sent.max <= pair[1].sent.max, "sent bytes only grow");
        }
        for r in &t.rows {
            for s in [r.sent, r.stored] {
                assert!(s.min as f64 <= s.mean && s.mean <= s.max as f64, "{r:?}");
                assert!(s.min <= s.median && s.median <= s.max, "{r:?}");
            }
        }
        let table = t.table();
        assert_eq!(table.rows(), t.rows.len());
        // A chain run's chain-size samples (every 100 s, each before the events at its time)
        // are the ledger's own count of the same means: the rows every 100 s agree.
        if aggregation == Aggregation::Chain {
            let every_100 = traffic(&path, SimTime(100_000)).unwrap();
            let before_end = &every_100.rows[1..every_100.rows.len() - 1];
            assert!(!before_end.is_empty());
            for (row, sample) in before_end.iter().zip(&summary.ledger.chain_bytes) {
                assert_eq!(row.time.secs(), sample.time_s);
                assert_eq!(row.sent.mean, sample.sent_mean);
                assert_eq!(row.stored.mean, sample.stored_mean);
            }
        }
        std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
    }

    #[test]
    fn the_last_row_is_the_summarys_end_values_in_every_mode() {
        check(Aggregation::Chain, RoundProtocol::Rounds);
        check(Aggregation::Chain, RoundProtocol::Buffered);
        check(Aggregation::Gossip, RoundProtocol::Rounds);
        check(Aggregation::Central, RoundProtocol::Rounds);
    }

    #[test]
    fn a_period_of_zero_or_past_any_run_is_refused() {
        for ms in [0, MAX_PERIOD_MS + 1] {
            let e = traffic(Path::new("no-such.swlog"), SimTime(ms)).unwrap_err();
            assert!(
                matches!(e, InspectError::Period { .. }) && e.to_string().contains("give one"),
                "{e}"
            );
        }
    }

    #[test]
    fn a_truncated_or_corrupt_log_is_an_error_naming_the_file_and_the_fix() {
        let (path, _) = short_run(Aggregation::Central, RoundProtocol::Rounds);
        let bytes = std::fs::read(&path).unwrap();
        let cut = path.with_file_name("cut.swlog");
        std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
        let e = traffic(&cut, SimTime(30_000)).unwrap_err().to_string();
        assert!(
            e.contains("cut.swlog") && e.contains("truncated") && e.contains("Re-run"),
            "{e}"
        );
        let mut altered = bytes.clone();
        let at = bytes.len() / 2;
        altered[at] ^= 0x40;
        let bad = path.with_file_name("altered.swlog");
        std::fs::write(&bad, &altered).unwrap();
        let e = traffic(&bad, SimTime(30_000)).unwrap_err().to_string();
        assert!(e.contains("altered.swlog") && e.contains("re-run"), "{e}");
        std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
    }
}

//! Folding a log's records into the state while noting each robot's last learning report:
//! one record at a time (the index), or up to one record with the world folded on a second
//! thread (a block's report from the sidecar).

use std::sync::mpsc::SyncSender;

use super::error::InspectError;
use crate::config::Config;
use crate::event::{Event, Record};
use crate::ledger::Ledger;
use crate::log::LogReader;
use crate::metrics::{LearnReport, Metrics};
use crate::replay::{self, ReplayError};
use crate::state::State;
use crate::types::SimTime;

/// Each robot's last learning report so far, with its time.
pub type LastLearning = Vec<Option<(SimTime, LearnReport)>>;

/// Folds one record into `state` (events) or checks it (checkpoints).
pub(super) fn fold_record(
    state: &mut State,
    learned: &mut LastLearning,
    name: &str,
    index: u64,
    record: &Record,
) -> Result<(), InspectError> {
    fold_record_checked(state, learned, name, index, record, true)
}

/// [`fold_record`], checking a checkpoint only when `check` is set.
fn fold_record_checked(
    state: &mut State,
    learned: &mut LastLearning,
    name: &str,
    index: u64,
    record: &Record,
    check: bool,
) -> Result<(), InspectError> {
    if check || matches!(record, Record::Event { .. }) {
        replay::fold_record(state, name, index, record)?;
    }
    if let Record::Event { time, event } = record {
        note_learning(learned, *time, event);
    }
    Ok(())
}

/// Keeps a robot's last learning report.
fn note_learning(learned: &mut LastLearning, time: SimTime, event: &Event) {
    if let Event::Learn(report) = event {
        if let Some(slot) = learned.get_mut(report.robot as usize) {
            *slot = Some((time, report.clone()));
        }
    }
}

/// Ticks handed to the world's thread at a time.
const TICK_BATCH: usize = 256;

/// Folds the records of `reader` up to and including record `stop`, checking only the
/// checkpoint at `stop` (see [`block_report_indexed`](super::block_report_indexed)), and
/// returns that record's time. The world's reducer runs on a second thread: ticks touch only
/// the world and every other event never reads it, so the two halves of the state are folded
/// side by side and meet at `stop` and at reconfigurations (folded with the whole state). Same
/// result as a sequential fold.
pub(super) fn fold_to_record(
    reader: &mut Reader,
    state: &mut State,
    learned: &mut LastLearning,
    config: &mut Config,
    name: &str,
    stop: u64,
) -> Result<SimTime, InspectError> {
    loop {
        let (index, record) = fold_side_by_side(reader, state, learned, name, stop)?;
        fold_record_checked(state, learned, name, index, &record, index == stop)?;
        if let Some(next) = replay::reconfigured(&record) {
            *config = next;
        }
        if index == stop {
            return Ok(record.time());
        }
    }
}

/// The log reader of a file.
type Reader = LogReader<std::io::BufReader<std::fs::File>>;

/// Ticks with their record index and time, on their way to the world's thread.
type TickBatch = Vec<(u64, SimTime, crate::world::TickEvent)>;

/// What the reader's thread folds: everything but the world.
struct LedgerSide<'a> {
    ledger: &'a mut Ledger,
    metrics: &'a mut Metrics,
    learned: &'a mut LastLearning,
}

/// Folds records up to the next one that needs the whole state (record `stop` or a
/// reconfiguration), the world on a second thread and the rest on this one, and returns that
/// record unfolded.
fn fold_side_by_side(
    reader: &mut Reader,
    state: &mut State,
    learned: &mut LastLearning,
    name: &str,
    stop: u64,
) -> Result<(u64, Record), InspectError> {
    std::thread::scope(|scope| {
        let State {
            world,
            ledger,
            metrics,
            ..
        } = &mut *state;
        let (to_world, from_reader) = std::sync::mpsc::sync_channel::<TickBatch>(8);
        let worker = scope.spawn(move || {
            for batch in from_reader {
                for (index, time, tick) in batch {
                    crate::state::apply_tick(world, time, &tick)
                        .map_err(|source| (index, time, source))?;
                }
            }
            Ok::<(), (u64, SimTime, crate::state::ApplyError)>(())
        });
        let mut batch: TickBatch = Vec::with_capacity(TICK_BATCH);
        let side = LedgerSide {
            ledger,
            metrics,
            learned,
        };
        let result = read_to_meet(reader, side, &to_world, &mut batch, name, stop);
        if !batch.is_empty() {
            let _ = to_world.send(batch);
        }
        drop(to_world);
        // A failed tick comes before anything the reader failed on: report it first.
        if let Err((index, time, source)) = worker.join().expect("the world's fold never panics") {
            return Err(InspectError::Replay(ReplayError::Apply {
                path: name.to_string(),
                index,
                kind: "tick",
                time,
                cause: source,
            }));
        }
        Ok(result?.expect("the world's thread stops only on an error"))
    })
}

/// The reader's side of [`fold_side_by_side`]: reads records, sends ticks to the world's thread
/// in batches, folds ledger and learning events, and returns the record where the halves meet;
/// `None` when the world's thread stopped (on an error, reported after the join). Ticks not
/// sent yet are left in `batch`.
fn read_to_meet(
    reader: &mut Reader,
    side: LedgerSide<'_>,
    to_world: &SyncSender<TickBatch>,
    batch: &mut TickBatch,
    name: &str,
    stop: u64,
) -> Result<Option<(u64, Record)>, InspectError> {
    loop {
        let Some(record) = reader.next_record().map_err(ReplayError::from)? else {
            return Err(InspectError::Inconsistent {
                path: name.to_string(),
                message: format!("the log ends before record {stop} named by its index"),
            });
        };
        let index = reader.index() - 1;
        if index == stop {
            return Ok(Some((index, record)));
        }
        match record {
            Record::Event {
                time,
                event: Event::Tick(tick),
            } => {
                batch.push((index, time, tick));
                if batch.len() == TICK_BATCH && to_world.send(std::mem::take(batch)).is_err() {
                    return Ok(None);
                }
            }
            Record::Event {
                time,
                event: ref event @ (Event::Ledger(_) | Event::Learn(_)),
            } => {
                crate::state::apply_ledger_side(side.ledger, side.metrics, time, event).map_err(
                    |source| ReplayError::Apply {
                        path: name.to_string(),
                        index,
                        kind: event.kind(),
                        time,
                        cause: source,
                    },
                )?;
                note_learning(side.learned, time, event);
            }
            Record::Checkpoint(_) => {}
            other => return Ok(Some((index, other))),
        }
    }
}

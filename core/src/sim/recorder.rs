//! Where the driver's decisions go: each event is folded into the reduced state, then queued as
//! a record, and the wall time spent is attributed to the parts of a run.

use std::collections::VecDeque;

use crate::event::{CheckpointCause, Event, Record};
use crate::state::State;
use crate::types::SimTime;

/// The parts of a run whose wall time a [`Profiler`] can attribute.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Part {
    /// Controllers, physics, sensing, data.
    World,
    /// Sealing, gossip, block validation and contract execution.
    Ledger,
    /// Local training and forging.
    Learning,
    /// State digests for checkpoints.
    Checkpoint,
    /// Writing the log (the caller's own work).
    Log,
}

/// Receives the driver's part switches; the command-line tool implements it with a clock.
/// (The core never reads the clock itself.)
pub trait Profiler: Send {
    /// From now on, time is spent in `part`.
    fn switch(&mut self, part: Part);
}

/// The reduced state, the records not yet handed out, and the profiler: the one place every
/// decided event passes through, so that no event is recorded without being folded first.
pub(super) struct Recorder {
    pub(super) state: State,
    pub(super) queue: VecDeque<Record>,
    pub(super) profiler: Option<Box<dyn Profiler>>,
}

impl Recorder {
    pub(super) fn new(state: State) -> Recorder {
        Recorder {
            state,
            queue: VecDeque::new(),
            profiler: None,
        }
    }

    /// From now on, time is spent in `part`.
    pub(super) fn switch(&mut self, part: Part) {
        if let Some(p) = self.profiler.as_mut() {
            p.switch(part);
        }
    }

    /// Folds `event` and queues its record.
    pub(super) fn emit(&mut self, time: SimTime, event: Event) {
        self.state
            .apply(time, &event)
            .unwrap_or_else(|e| panic!("the driver produced an event its own state rejects: {e}"));
        self.queue.push_back(Record::Event { time, event });
    }

    /// Queues a checkpoint of the current state.
    pub(super) fn checkpoint(&mut self, time: SimTime, cause: CheckpointCause) {
        self.switch(Part::Checkpoint);
        let c = self.state.checkpoint(time, cause);
        self.queue.push_back(Record::Checkpoint(c));
    }
}

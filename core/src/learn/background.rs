//! Trainings started on rayon's pool before their result is needed.
//!
//! The driver knows some trainings before it needs them: the speculated phases of the
//! look-ahead window, and the due trainings whose outcomes it reads only after it has planned
//! every robot of the tick. [`Spawned::start`] queues such a training on the pool and returns
//! at once, so the driver goes on (world, ledger, the next ticks) while the cores train;
//! [`Spawned::wait`] then takes the outcome. A training is a pure function of its job, so who
//! runs it, and when, cannot change a bit.
//!
//! A waiter never blocks on a training nobody started: if the job is still queued, the waiter
//! takes it and runs it itself (so a driver that runs on a pool thread, as `sweep` runs them,
//! cannot deadlock the pool, and a due training never waits behind speculated ones). Dropping
//! a [`Spawned`] whose job has not started cancels it: the pool thread that pops it finds no
//! one holding it and returns (a stale speculation costs nothing if it never started).

use std::sync::{Arc, Condvar, Mutex, MutexGuard};

use super::{Threads, TrainJob, TrainOutcome};

/// Where a started training is.
enum Stage {
    /// Waiting in the pool's queue.
    Queued(Box<TrainJob>),
    /// A thread is computing it.
    Running,
    /// Computed, not yet taken.
    Done(TrainOutcome),
    /// Taken by [`Spawned::wait`] (only its own handle can take it).
    Taken,
}

struct Slot {
    stage: Mutex<Stage>,
    done: Condvar,
}

impl Slot {
    fn lock(&self) -> MutexGuard<'_, Stage> {
        // A poisoned lock means a training panicked on another thread; the stage is still
        // consistent (it is only replaced whole), so carry on with it.
        self.stage.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Takes the job if nobody has started it yet, marking it running.
    fn claim(&self) -> Option<Box<TrainJob>> {
        let mut stage = self.lock();
        match std::mem::replace(&mut *stage, Stage::Running) {
            Stage::Queued(job) => Some(job),
            other => {
                *stage = other;
                None
            }
        }
    }
}

/// A training queued on rayon's pool (see the module documentation).
pub struct Spawned {
    slot: Arc<Slot>,
}

impl Spawned {
    /// Queues `job` on rayon's global pool and returns at once.
    pub fn start(job: TrainJob) -> Spawned {
        let slot = Arc::new(Slot {
            stage: Mutex::new(Stage::Queued(Box::new(job))),
            done: Condvar::new(),
        });
        let weak = Arc::downgrade(&slot);
        rayon::spawn(move || {
            // Nobody holds the handle any more: the training was cancelled.
            let Some(slot) = weak.upgrade() else { return };
            let Some(job) = slot.claim() else { return };
            // One thread: the pool's other threads have trainings of their own to run. Counted
            // as in progress, so a training run alone elsewhere takes no helper meanwhile.
            let outcome = {
                let _active = super::pair::Active::enter();
                job.run_with(Threads::One)
            };
            *slot.lock() = Stage::Done(outcome);
            slot.done.notify_all();
        });
        Spawned { slot }
    }

    /// The training's outcome: computed here if it has not started yet, else waited for.
    pub fn wait(self) -> TrainOutcome {
        if let Some(job) = self.slot.claim() {
            // Nobody else reads the stage of a job its own handle runs.
            return job.run();
        }
        let mut stage = self.slot.lock();
        loop {
            match std::mem::replace(&mut *stage, Stage::Taken) {
                Stage::Done(outcome) => return outcome,
                Stage::Running => {
                    *stage = Stage::Running;
                    stage = self
                        .slot
                        .done
                        .wait(stage)
                        .unwrap_or_else(|e| e.into_inner());
                }
                Stage::Queued(_) | Stage::Taken => {
                    unreachable!("a claimed training is running or done until its handle takes it")
                }
            }
        }
    }
}

impl std::fmt::Debug for Spawned {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let stage = match *self.slot.lock() {
            Stage::Queued(_) => "queued",
            Stage::Running => "running",
            Stage::Done(_) => "done",
            Stage::Taken => "taken",
        };
        f.debug_struct("Spawned").field("stage", &stage).finish()
    }
}

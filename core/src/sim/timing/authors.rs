//! `authors`: the schedule of the authors' code (GitHub teksander/geth-argos,
//! `TrajectoryPrediction/`; docs/SPEC.md section 3, "The authors' timing").
//!
//! - Every robot's timer starts at time 0 (each controller's `init()` signals its docker side
//!   at the same start) and fires `learn.training_period_s` later; in cycle `c` a robot's
//!   timer fires at `c x period + jitter`, the jitter drawn uniformly in
//!   `[0, learn.authors_timing.byzantine_jitter_s)` per robot and cycle (`Purpose::Timing`,
//!   one substream per cycle).
//! - A Byzantine robot never trains: its phase begins and its submission leaves when its timer
//!   fires, every cycle, so the Byzantine robots stay in step (`bad_behaviour` in
//!   `controllers/docker/fedlerv2.py`).
//! - An honest robot's training goes to one first-come-first-served server
//!   (`tfserver/main.py` serves one robot at a time): the robot arrives when its timer fires,
//!   its phase begins when the server takes it (it then reads the model at its node's head
//!   and its data, as `server_training_v3` does after the server's "ready"), and its
//!   submission leaves `learn.authors_timing.service_time_s` later. Arrivals at the same
//!   millisecond are served in robot order. Its timer restarts when the training returns, so
//!   its next arrival is a period after its submission (end to start); the first arrival is
//!   cycle 1's.
//! - Every robot submits whenever its phase comes, even if its node holds its submission of
//!   the round: the contract refuses the second (`duplicate`), as the authors' `require` does
//!   and their `try`/`except` swallows.
//!
//! The server's queue depends only on the schedule itself (every honest phase occupies the
//! server, whatever the robot then submits), so the slots are generated in arrival order, as
//! far as a request needs, and do not depend on the order of the requests.
//!
//! After a fork's reconfiguration each robot's next phase is kept; a Byzantine robot then
//! follows the new period's cycles (`c x period`, the first after its kept phase), an honest
//! one arrives a new period after its kept phase's submission, and the server is busy until
//! the last kept honest submission.

use std::collections::VecDeque;

use super::{Setup, Slot, TimingModel};
use crate::rng::{self, Purpose};
use crate::types::RobotId;

/// The authors' schedule: the Byzantine robots' cycles and the honest robots' queue.
pub struct Authors {
    seed: u64,
    byzantine: Vec<bool>,
    period_ms: u64,
    jitter_ms: u64,
    service_ms: u64,
    /// Per robot: the phase of the first slot held, and the slots generated from it on.
    slots: Vec<(u64, VecDeque<Slot>)>,
    /// Per Byzantine robot: the cycle of its next slot to generate.
    next_cycle: Vec<u64>,
    /// Per honest robot: when it next arrives at the server, ms.
    arrival_ms: Vec<u64>,
    /// When the server is next free, ms.
    free_ms: u64,
}

impl Authors {
    /// The schedule of `setup`.
    pub fn new(setup: &Setup) -> Authors {
        let robots = setup.byzantine.len();
        let mut a = Authors {
            seed: setup.seed,
            byzantine: setup.byzantine.to_vec(),
            period_ms: setup.period_ms,
            jitter_ms: setup.jitter_ms,
            service_ms: setup.service_ms,
            slots: vec![(0, VecDeque::new()); robots],
            next_cycle: vec![1; robots],
            arrival_ms: vec![0; robots],
            free_ms: 0,
        };
        for r in 0..robots as RobotId {
            a.arrival_ms[r as usize] = a.fires_ms(r, 1);
        }
        if let Some(kept) = setup.kept {
            for (r, &(phase, slot)) in kept.iter().enumerate() {
                a.slots[r] = (phase, VecDeque::from([slot]));
                if a.byzantine[r] {
                    a.next_cycle[r] = slot.begin_ms / a.period_ms + 1;
                } else {
                    a.arrival_ms[r] = slot.ready_ms + a.period_ms;
                    a.free_ms = a.free_ms.max(slot.ready_ms);
                }
            }
        }
        a
    }

    /// When `robot`'s timer fires in cycle `cycle`: the cycle's time plus its jitter.
    fn fires_ms(&self, robot: RobotId, cycle: u64) -> u64 {
        let jitter = if self.jitter_ms == 0 {
            0
        } else {
            rng::substream(self.seed, Purpose::Timing, robot, cycle).below(self.jitter_ms)
        };
        cycle * self.period_ms + jitter
    }

    /// Serves the honest robot that arrives first (ties: the lowest id): its slot, and its
    /// next arrival a period after the training returns.
    fn serve_next(&mut self) {
        let (r, arrival) = (0..self.byzantine.len())
            .filter(|&r| !self.byzantine[r])
            .map(|r| (r, self.arrival_ms[r]))
            .min_by_key(|&(r, t)| (t, r))
            .expect("only an honest robot's slot is served");
        let begin_ms = arrival.max(self.free_ms);
        let ready_ms = begin_ms + self.service_ms;
        self.free_ms = ready_ms;
        self.arrival_ms[r] = ready_ms + self.period_ms;
        self.slots[r].1.push_back(Slot { begin_ms, ready_ms });
    }
}

impl TimingModel for Authors {
    fn slot(&mut self, robot: RobotId, phase: u64) -> Slot {
        let i = robot as usize;
        debug_assert!(phase >= self.slots[i].0, "a forgotten phase");
        let offset = (phase - self.slots[i].0) as usize;
        while self.slots[i].1.len() <= offset {
            if self.byzantine[i] {
                let at = self.fires_ms(robot, self.next_cycle[i]);
                self.next_cycle[i] += 1;
                self.slots[i].1.push_back(Slot {
                    begin_ms: at,
                    ready_ms: at,
                });
            } else {
                self.serve_next();
            }
        }
        self.slots[i].1[offset]
    }

    fn forget(&mut self, robot: RobotId, phase: u64) {
        let (first, held) = &mut self.slots[robot as usize];
        while *first < phase && !held.is_empty() {
            held.pop_front();
            *first += 1;
        }
    }

    fn submits_blind(&self) -> bool {
        true
    }
}

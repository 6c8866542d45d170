//! The world's threads: large swarms step their robots in parallel, with the same bits as one
//! thread (issue 56).
//!
//! Every parallel part of a tick is a pure function of the state before it, per robot, and its
//! results are merged in robot order:
//! - the controllers' decisions (each robot reads the world and its own controller);
//! - the range-and-bearing contacts (pairs `i < j` found and sorted per `i`, then inserted in
//!   robot order, which leaves every list ascending). The same search of the grid also counts
//!   the overlaps and finds each robot's nearest other robot, which the next tick's physics
//!   reads;
//! - the sensing (each robot's own random stream, recorder and expiry). The running digests
//!   `reading_mix` and `sample_chain` are folded afterwards, each in robot order, one on each of
//!   two threads.
//!
//! The physics is sequential by definition (a robot moves against the robots before it, already
//! moved): `physics::step_parallel` computes in parallel only the robots that no other robot
//! can reach this tick, and moves the others in robot order, which gives the sequential step's
//! result exactly (see there).
//!
//! A tick's physics and sensing run inside one `install` of the pool (`World::apply_on`), so
//! the driver forks from outside the pool once for them (a fork from outside costs 12-40 us,
//! a few percent of a 1000-robot tick; docs/PERFORMANCE.md); the decisions fork once more.
//!
//! The threads are their own rayon pool ([`Workers`]), not the global one: the global pool runs
//! the background trainings (`learn/background.rs`), and a world step queued behind 25 ms
//! trainings would stall the driver every tick. A swarm of fewer than
//! [`PARALLEL_MIN_ROBOTS`] robots, or a pool of one thread, takes the sequential code.

use std::sync::OnceLock;

use rayon::ThreadPool;

/// The smallest swarm stepped in parallel: below it, a tick is too short (15 robots: about
/// 10 us) for the fork and join to pay.
pub const PARALLEL_MIN_ROBOTS: usize = 128;

/// Robots per parallel piece: enough work per piece (a few tens of microseconds) that the
/// split costs little, and enough pieces for two threads to balance.
pub(super) const PIECE: usize = 32;

/// The threads a world step may use: a rayon pool, or none (the sequential code).
#[derive(Clone, Copy, Debug, Default)]
pub struct Workers<'a> {
    pool: Option<&'a ThreadPool>,
}

impl<'a> Workers<'a> {
    /// The sequential code, on the calling thread.
    pub const SEQUENTIAL: Workers<'static> = Workers { pool: None };

    /// The threads of `pool` (a pool of one thread takes the sequential code).
    pub fn on(pool: &'a ThreadPool) -> Workers<'a> {
        Workers {
            pool: (pool.current_num_threads() > 1).then_some(pool),
        }
    }

    /// The pool, when a swarm of `robots` is to be stepped in parallel.
    pub(super) fn for_robots(self, robots: usize) -> Option<&'a ThreadPool> {
        self.pool.filter(|_| robots >= PARALLEL_MIN_ROBOTS)
    }
}

impl Workers<'static> {
    /// The process's world threads: as many as rayon's global pool has (`RAYON_NUM_THREADS`,
    /// else one per core), in a pool of their own built on first use.
    pub fn default_pool() -> Workers<'static> {
        static POOL: OnceLock<Option<ThreadPool>> = OnceLock::new();
        let pool = POOL.get_or_init(|| {
            let threads = rayon::current_num_threads();
            (threads > 1)
                .then(|| {
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .thread_name(|i| format!("swarmfl-world-{i}"))
                        .build()
                        .ok()
                })
                .flatten()
        });
        Workers {
            pool: pool.as_ref(),
        }
    }
}

#[cfg(test)]
mod tests;

//! A synthetic swarm for tests and benchmarks of the ledger without the world: points that
//! wander in a square, peers within a radio range, and a driver loop that applies every
//! network event tick by tick. Nothing here is used by a real run.

use super::{Ledger, LedgerError, LedgerEvent, Network};
use crate::rng::{self, Purpose, Rng};
use crate::types::{RobotId, SimTime};

/// Points moving at constant speed in a walled square, turning at random.
#[derive(Clone, Debug)]
pub struct Wanderers {
    side_m: f64,
    range_m: f64,
    speed_mps: f64,
    positions: Vec<(f64, f64)>,
    headings: Vec<f64>,
    rngs: Vec<Rng>,
}

impl Wanderers {
    /// `robots` points placed uniformly in a `side_m` square, from `seed`.
    pub fn new(robots: u32, seed: u64, side_m: f64, range_m: f64, speed_mps: f64) -> Wanderers {
        let mut rngs: Vec<Rng> = (0..robots)
            .map(|r| rng::stream(seed, Purpose::Controller, r))
            .collect();
        let positions = rngs
            .iter_mut()
            .map(|r| (r.range(0.0, side_m), r.range(0.0, side_m)))
            .collect();
        let headings = rngs
            .iter_mut()
            .map(|r| r.range(0.0, std::f64::consts::TAU))
            .collect();
        Wanderers {
            side_m,
            range_m,
            speed_mps,
            positions,
            headings,
            rngs,
        }
    }

    /// Moves every point for `dt_s` seconds.
    pub fn step(&mut self, dt_s: f64) {
        for i in 0..self.positions.len() {
            if self.rngs[i].chance(0.05) {
                self.headings[i] = self.rngs[i].range(0.0, std::f64::consts::TAU);
            }
            let (x, y) = self.positions[i];
            let nx = x + self.speed_mps * dt_s * libm::cos(self.headings[i]);
            let ny = y + self.speed_mps * dt_s * libm::sin(self.headings[i]);
            if (0.0..=self.side_m).contains(&nx) && (0.0..=self.side_m).contains(&ny) {
                self.positions[i] = (nx, ny);
            } else {
                self.headings[i] += std::f64::consts::PI;
            }
        }
    }

    /// Each point's peers: the others within range, ascending.
    pub fn peers(&self) -> Vec<Vec<RobotId>> {
        let r2 = self.range_m * self.range_m;
        let n = self.positions.len();
        (0..n)
            .map(|i| {
                (0..n)
                    .filter(|&j| {
                        let (a, b) = (self.positions[i], self.positions[j]);
                        j != i && (a.0 - b.0) * (a.0 - b.0) + (a.1 - b.1) * (a.1 - b.1) <= r2
                    })
                    .map(|j| j as RobotId)
                    .collect()
            })
            .collect()
    }
}

/// Everyone hears everyone.
pub fn full_mesh(robots: u32) -> Vec<Vec<RobotId>> {
    (0..robots)
        .map(|i| (0..robots).filter(|&j| j != i).collect())
        .collect()
}

/// Two groups that hear only their own members: robots below `split` and the others.
pub fn partition(robots: u32, split: u32) -> Vec<Vec<RobotId>> {
    (0..robots)
        .map(|i| {
            (0..robots)
                .filter(|&j| j != i && (i < split) == (j < split))
                .collect()
        })
        .collect()
}

/// Applies every network event due at or before `until` to the ledger, appending each to
/// `log`: what a driver does after each world tick.
pub fn drain(
    ledger: &mut Ledger,
    network: &mut Network,
    until: SimTime,
    peers: &[Vec<RobotId>],
    log: &mut Vec<(SimTime, LedgerEvent)>,
) -> Result<(), LedgerError> {
    while let Some((at, event)) = network.next_event(ledger, until, peers) {
        ledger.apply(at, &event)?;
        log.push((at, event));
    }
    Ok(())
}

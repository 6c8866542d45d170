//! A synthetic swarm for tests and benchmarks of the ledger without the world: points that
//! wander in a square, peers within a radio range, and a driver loop that applies every
//! network event tick by tick. Nothing here is used by a real run.

use std::sync::Arc;

use super::{Ledger, LedgerError, LedgerEvent, Network};
use crate::config::Config;
use crate::contract::{Call, ContractParams};
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

/// The shape of a synthetic run that loads the ledger as a `paper` run would.
#[derive(Clone, Debug)]
pub struct Workload {
    /// Simulated seconds.
    pub duration_s: u64,
    /// Each robot submits a model every this many seconds (offset per robot).
    pub submit_period_s: u64,
    /// Weights per submitted model.
    pub weights: usize,
    /// Side of the square the robots wander in, metres.
    pub side_m: f64,
    /// Radio range, metres.
    pub range_m: f64,
    /// Speed of the robots, m/s.
    pub speed_mps: f64,
}

impl Workload {
    /// The `paper` run's load: 5000 s, a 2848-weight submission per robot every 100 s (750
    /// submissions with 15 robots), a 5 m arena, 2.5 m range, 0.025 m/s.
    pub fn paper() -> Workload {
        Workload {
            duration_s: 5000,
            submit_period_s: 100,
            weights: 2848,
            side_m: 5.0,
            range_m: 2.5,
            speed_mps: 0.025,
        }
    }
}

/// Runs the ledger alone under `workload` (robots, tick and ledger settings from `config`):
/// wandering robots, peers refreshed every `world.peer_refresh_s`, a `SubmitModel` with
/// random fixed-point weights (uniform in +-0.5 at scale `contract.weight_scale`) and the
/// stake from each robot every period, every event applied and handed to `sink`. For
/// benchmarks and size estimates.
pub fn run_workload(
    config: &Config,
    seed: u64,
    workload: &Workload,
    mut sink: impl FnMut(SimTime, &LedgerEvent),
) -> Result<Ledger, LedgerError> {
    let robots = config.world.robots;
    let params = ContractParams::from_config(config, Arc::from(vec![0i64; workload.weights]));
    let mut ledger = Ledger::new(config, seed, params);
    let mut net = Network::new(config, seed);
    let mut swarm = Wanderers::new(
        robots,
        seed,
        workload.side_m,
        workload.range_m,
        workload.speed_mps,
    );
    let mut weights_rng = rng::stream(seed, Purpose::Byzantine, 0);
    let tick_ms = ((config.run.tick_s * 1000.0).round() as u64).max(1);
    let refresh_ms = ((config.world.peer_refresh_s * 1000.0).round() as u64).max(tick_ms);
    let period_ms = workload.submit_period_s * 1000;
    let stake_units = config.contract.stake_tokens * config.contract.token_units;
    let scale = config.contract.weight_scale as f64;
    let mut peers = swarm.peers();
    let mut log = Vec::new();
    let mut t = 0;
    while t <= workload.duration_s * 1000 {
        if t > 0 && t % refresh_ms == 0 {
            swarm.step(refresh_ms as f64 / 1000.0);
            peers = swarm.peers();
        }
        drain(&mut ledger, &mut net, SimTime(t), &peers, &mut log)?;
        for (at, event) in log.drain(..) {
            sink(at, &event);
        }
        for robot in 0..robots {
            let offset_ms = period_ms * u64::from(robot) / u64::from(robots) / tick_ms * tick_ms;
            if period_ms > 0
                && t >= offset_ms + period_ms
                && (t - offset_ms).is_multiple_of(period_ms)
            {
                let weights: Arc<[i64]> = (0..workload.weights)
                    .map(|_| (weights_rng.range(-0.5, 0.5) * scale).round() as i64)
                    .collect();
                let call = Call::SubmitModel {
                    weights,
                    samples: 100,
                };
                let event = LedgerEvent::Submit {
                    tx: ledger.make_tx(robot, stake_units, call),
                };
                ledger.apply(SimTime(t), &event)?;
                sink(SimTime(t), &event);
            }
        }
        t += tick_ms;
    }
    Ok(ledger)
}

//! The matched ideal (`learn.aggregation = "matched"`, with `contract.protocol = "buffered"`):
//! the ideal server of the buffered protocol, against which the chain's buffered runs are
//! measured. `central` is the ideal of the paper's rounds (it waits for a quorum of half the
//! swarm, so at 1000 robots it makes a handful of steps against the chain's hundreds); this
//! one applies the buffered contract's rule (`contract/buffered.rs`) to the same trainings:
//! - a robot's phase starts from the server's newest version, with no delay (its `Merge`
//!   records that version as the base of its next update);
//! - its upload is the update `u = w - base` (clamped to int48, as on chain), with every
//!   upload accepted: no staleness bound, no outlier check, no duplicate-base refusal, no
//!   stake;
//! - every `contract.buffer_size` (K) updates, the server steps: with `tau_k` the versions
//!   between update k's base and the newest, `w += eta * sum n_k S(tau_k) u_k / sum n_k
//!   S(tau_k)` (FedAvg's integer quotient with `contract.fedavg_rounding`, the staleness weight
//!   `S` of `contract.staleness_exponent` computed as the contract's table is, the server step
//!   `eta = contract.server_step`), clamped to int48. Under rounds there is no buffer to
//!   match: `config/protocol_fit.rs` refuses it there, and K above the swarm.

use std::sync::Arc;

use super::gossip::{Entry, EntryId};
use crate::config::{Config, FedAvgRounding};
use crate::contract::buffered::{staleness_weight, STEP_SCALE};
use crate::contract::payout::{self, div_round_half_away};
use crate::contract::MAX_WEIGHT_MAGNITUDE;
use crate::types::{Digest, RobotId, SimTime};

const MAX_W: i128 = MAX_WEIGHT_MAGNITUDE as i128 - 1;

/// One buffered update.
#[derive(Clone, Debug)]
struct Pending {
    entry: Arc<Entry>,
    base_version: u64,
    update: Vec<i64>,
}

/// The matched ideal server's state.
#[derive(Clone, Debug)]
pub struct MatchedServer {
    /// The shared model (the newest version).
    pub weights: Arc<[i64]>,
    /// The version before it (None before the first step).
    pub previous: Option<Arc<[i64]>>,
    /// Steps so far: the newest version's number.
    pub version: u64,
    /// Per robot: the version and model its running phase started from (genesis before any).
    bases: Vec<(u64, Arc<[i64]>)>,
    /// Uploads per robot (an upload's clock).
    uploads: Vec<u64>,
    /// The open buffer, in arrival order.
    pending: Vec<Pending>,
    /// When each version was made (`made_ms[v]`, genesis at 0).
    made_ms: Vec<u64>,
    /// Every update's base age at its upload: (versions, milliseconds), in upload order (a
    /// figure for the summary; the state digest has the versions already).
    pub ages: Vec<(u64, u64)>,
    buffer_size: usize,
    exponent: f64,
    step_units: u64,
    rounding: FedAvgRounding,
}

impl MatchedServer {
    /// The server of `config` holding `genesis`.
    pub fn new(config: &Config, genesis: Arc<[i64]>) -> MatchedServer {
        let c = &config.contract;
        let robots = config.world.robots as usize;
        MatchedServer {
            bases: vec![(0, genesis.clone()); robots],
            weights: genesis,
            previous: None,
            version: 0,
            uploads: vec![0; robots],
            pending: Vec::new(),
            made_ms: vec![0],
            ages: Vec::new(),
            buffer_size: c.buffer_size.max(1) as usize,
            exponent: c.staleness_exponent,
            step_units: (c.server_step * STEP_SCALE as f64).round() as u64,
            rounding: c.fedavg_rounding,
        }
    }

    /// The entry `robot`'s next upload makes (its identity in learning reports).
    pub fn next_entry(&self, robot: RobotId, samples: u64, weights: Arc<[i64]>) -> Entry {
        let clock = self.uploads.get(robot as usize).map_or(1, |u| u + 1);
        Entry::new(EntryId { key: robot, clock }, samples, weights)
    }

    /// The updates waiting in the open buffer, as (robot, model) in arrival order.
    pub fn pending(&self) -> impl Iterator<Item = (RobotId, &Arc<Entry>)> {
        self.pending.iter().map(|p| (p.entry.id.key, &p.entry))
    }

    /// `robot`'s phase starts: the newest version is its next update's base.
    pub fn download(&mut self, robot: RobotId) -> Result<(), String> {
        let robots = self.bases.len();
        let base = self
            .bases
            .get_mut(robot as usize)
            .ok_or_else(|| format!("robot {robot} in a swarm of {robots}"))?;
        *base = (self.version, self.weights.clone());
        Ok(())
    }

    /// `robot`'s base: the version its running phase started from.
    pub fn base_version(&self, robot: RobotId) -> Option<u64> {
        self.bases.get(robot as usize).map(|b| b.0)
    }

    /// Folds an upload; returns the entry and, when it fills the buffer, the hashes of the
    /// updates aggregated (the new version is then in `weights`).
    pub fn upload(
        &mut self,
        time: SimTime,
        robot: RobotId,
        samples: u64,
        weights: Arc<[i64]>,
    ) -> Result<(Arc<Entry>, Option<Vec<Digest>>), String> {
        let i = robot as usize;
        if i >= self.uploads.len() || samples == 0 || weights.len() != self.weights.len() {
            return Err(format!(
                "upload of robot {robot} (swarm of {}): {} weights (want {}), {samples} samples \
                 (want >= 1)",
                self.uploads.len(),
                weights.len(),
                self.weights.len()
            ));
        }
        self.uploads[i] += 1;
        let (base_version, base) = self.bases[i].clone();
        let made = self
            .made_ms
            .get(base_version as usize)
            .copied()
            .unwrap_or(0);
        self.ages
            .push((self.version - base_version, time.0.saturating_sub(made)));
        let update = weights
            .iter()
            .zip(base.iter())
            .map(|(&w, &b)| (i128::from(w) - i128::from(b)).clamp(-MAX_W, MAX_W) as i64)
            .collect();
        let entry = Arc::new(Entry::new(
            EntryId {
                key: robot,
                clock: self.uploads[i],
            },
            samples,
            weights,
        ));
        self.pending.push(Pending {
            entry: entry.clone(),
            base_version,
            update,
        });
        if self.pending.len() < self.buffer_size {
            return Ok((entry, None));
        }
        let members = self.step();
        self.made_ms.push(time.0);
        Ok((entry, Some(members)))
    }

    /// Closes the buffer: the staleness- and sample-weighted mean update, the server step.
    fn step(&mut self) -> Vec<Digest> {
        let pending = std::mem::take(&mut self.pending);
        let weighted: Vec<u64> = pending
            .iter()
            .map(|p| {
                let tau = u32::try_from(self.version - p.base_version).unwrap_or(u32::MAX);
                p.entry
                    .samples
                    .saturating_mul(staleness_weight(self.exponent, tau))
            })
            .collect();
        let models: Vec<(&[i64], u64)> = pending
            .iter()
            .zip(&weighted)
            .map(|(p, &w)| (&p.update[..], w))
            .collect();
        let mean = payout::fedavg(&models, self.rounding);
        let step = i128::from(self.step_units);
        let next: Arc<[i64]> = self
            .weights
            .iter()
            .zip(mean)
            .map(|(&w, u)| {
                let d = div_round_half_away(i128::from(u) * step, i128::from(STEP_SCALE));
                (i128::from(w) + d).clamp(-MAX_W, MAX_W) as i64
            })
            .collect();
        self.previous = Some(std::mem::replace(&mut self.weights, next));
        self.version += 1;
        pending.iter().map(|p| p.entry.hash).collect()
    }

    /// Digest of the server's state.
    pub fn digest_into(&self, h: &mut blake3::Hasher) {
        h.update(b"matched v1");
        h.update(&self.version.to_le_bytes());
        h.update(&super::weights_digest(&self.weights).0);
        for (v, _) in &self.bases {
            h.update(&v.to_le_bytes());
        }
        for p in &self.pending {
            h.update(&p.entry.hash.0);
            h.update(&p.base_version.to_le_bytes());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Aggregation, Preset, RoundProtocol};

    fn config(k: u32) -> Config {
        let mut c = Preset::Paper.config();
        c.world.robots = 3;
        c.contract.protocol = RoundProtocol::Buffered;
        c.contract.buffer_size = k;
        c.learn.aggregation = Aggregation::Matched;
        c
    }

    #[test]
    fn steps_every_k_updates_by_the_staleness_weighted_mean_update() {
        let mut s = MatchedServer::new(&config(2), Arc::from(vec![0i64, 0]));
        s.download(0).unwrap();
        s.download(1).unwrap();
        let (_, none) = s
            .upload(SimTime(0), 0, 1, Arc::from(vec![10i64, -10]))
            .unwrap();
        assert!(none.is_none(), "one update of K = 2 does not step");
        let (_, members) = s
            .upload(SimTime(0), 1, 3, Arc::from(vec![2i64, 2]))
            .unwrap();
        // (1 * 10 + 3 * 2) / 4 = 4; (1 * -10 + 3 * 2) / 4 = -1: both fresh, equal staleness.
        assert_eq!(&s.weights[..], &[4, -1]);
        assert_eq!((s.version, members.unwrap().len()), (1, 2));
        // Robot 2 still trains from genesis (version 0, one behind); robot 0 from version 1.
        s.download(0).unwrap();
        s.upload(SimTime(0), 0, 1, Arc::from(vec![6i64, 1]))
            .unwrap(); // update (2, 2), S(0) = 65536
        s.upload(SimTime(0), 2, 1, Arc::from(vec![-8i64, 8]))
            .unwrap(); // update (-8, 8), S(1) = 46341
        let (s0, s1) = (65536i128, 46341i128);
        let want = |a: i128, b: i128| div_round_half_away(a * s0 + b * s1, s0 + s1);
        assert_eq!(
            &s.weights[..],
            &[4 + want(2, -8) as i64, -1 + want(2, 8) as i64]
        );
        assert_eq!(s.version, 2);
        assert_eq!(s.base_version(2), Some(0));
    }

    #[test]
    fn a_second_update_of_one_robot_counts_and_nothing_is_refused() {
        let mut s = MatchedServer::new(&config(2), Arc::from(vec![0i64]));
        s.upload(SimTime(0), 0, 1, Arc::from(vec![2i64])).unwrap();
        s.upload(SimTime(0), 0, 1, Arc::from(vec![4i64])).unwrap();
        assert_eq!((&s.weights[..], s.version), (&[3i64][..], 1));
        assert!(s.upload(SimTime(0), 5, 1, Arc::from(vec![1i64])).is_err());
        assert!(s.upload(SimTime(0), 1, 0, Arc::from(vec![1i64])).is_err());
    }
}

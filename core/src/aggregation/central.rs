//! The ideal central server, the upper bound every federated-learning paper reports: it
//! receives every upload the moment it is made, and aggregates FedAvg (the contract's integer
//! arithmetic, `contract::payout::fedavg`) as soon as the round holds a quorum of models (the
//! contract's quorum, `max(floor(contract.quorum_fraction * N), 1)`). No chain, no delay, no
//! security: every upload is accepted, one per robot and round (a robot whose model waits in
//! the open round skips its phase, as on the chain).

use std::sync::Arc;

use super::gossip::{Entry, EntryId};
use crate::config::FedAvgRounding;
use crate::contract::payout;
use crate::types::{Digest, RobotId};

/// The server's state.
#[derive(Clone, Debug)]
pub struct Server {
    /// The shared model.
    pub weights: Arc<[i64]>,
    /// The shared model before the last aggregation (None before the first).
    pub previous: Option<Arc<[i64]>>,
    /// Aggregations so far.
    pub round: u64,
    /// The open round's uploads, in arrival order.
    pending: Vec<(RobotId, Arc<Entry>)>,
    /// Uploads per robot (an upload's version number).
    uploads: Vec<u64>,
    /// Uploads refused because the robot's model already waited in the open round.
    pub duplicates: u64,
}

impl Server {
    /// A server holding the genesis model, for `robots` robots.
    pub fn new(genesis: Arc<[i64]>, robots: u32) -> Server {
        Server {
            weights: genesis,
            previous: None,
            round: 0,
            pending: Vec::new(),
            uploads: vec![0; robots as usize],
            duplicates: 0,
        }
    }

    /// The open round's uploads, in arrival order.
    pub fn pending(&self) -> &[(RobotId, Arc<Entry>)] {
        &self.pending
    }

    /// Whether `robot`'s model waits in the open round.
    pub fn has_pending(&self, robot: RobotId) -> bool {
        self.pending.iter().any(|(r, _)| *r == robot)
    }

    /// The entry `robot`'s next upload makes (its identity in learning reports).
    pub fn next_entry(&self, robot: RobotId, samples: u64, weights: Arc<[i64]>) -> Entry {
        let clock = self.uploads.get(robot as usize).map_or(1, |u| u + 1);
        Entry::new(EntryId { key: robot, clock }, samples, weights)
    }

    /// Folds an upload; returns the entry and, when it completes the quorum, the hashes of the
    /// aggregated models (the new shared model is then in `weights`). A robot's second upload
    /// in one round is counted in `duplicates` and left out.
    pub fn upload(
        &mut self,
        robot: RobotId,
        samples: u64,
        weights: Arc<[i64]>,
        quorum: usize,
        rounding: FedAvgRounding,
    ) -> Result<(Arc<Entry>, Option<Vec<Digest>>), String> {
        let Some(count) = self.uploads.get_mut(robot as usize) else {
            return Err(format!(
                "upload of robot {robot} in a swarm of {}",
                self.uploads.len()
            ));
        };
        if samples == 0 || weights.len() != self.weights.len() {
            return Err(format!(
                "upload of robot {robot}: {} weights (want {}), {samples} samples (want >= 1)",
                weights.len(),
                self.weights.len()
            ));
        }
        *count += 1;
        let entry = Arc::new(Entry::new(
            EntryId {
                key: robot,
                clock: *count,
            },
            samples,
            weights,
        ));
        if self.pending.iter().any(|(r, _)| *r == robot) {
            // A second model in one round (a waited phase and the next one leaving together):
            // refused, as the contract refuses a duplicate submission.
            self.duplicates += 1;
            return Ok((entry, None));
        }
        self.pending.push((robot, entry.clone()));
        if self.pending.len() < quorum.max(1) {
            return Ok((entry, None));
        }
        let models: Vec<(&[i64], u64)> = self
            .pending
            .iter()
            .map(|(_, e)| (&e.weights[..], e.samples))
            .collect();
        let aggregated: Arc<[i64]> = Arc::from(payout::fedavg(&models, rounding));
        let members = self.pending.iter().map(|(_, e)| e.hash).collect();
        self.pending.clear();
        self.previous = Some(std::mem::replace(&mut self.weights, aggregated));
        self.round += 1;
        Ok((entry, Some(members)))
    }

    /// Digest of the server's state.
    pub fn digest_into(&self, h: &mut blake3::Hasher) {
        h.update(&self.round.to_le_bytes());
        h.update(&self.duplicates.to_le_bytes());
        h.update(&super::weights_digest(&self.weights).0);
        for (r, e) in &self.pending {
            h.update(&r.to_le_bytes());
            h.update(&e.hash.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aggregates_fedavg_at_the_quorum_and_refuses_a_second_upload() {
        let mut s = Server::new(Arc::from(vec![0i64, 0]), 3);
        let (_, none) = s
            .upload(
                0,
                1,
                Arc::from(vec![10i64, -10]),
                2,
                FedAvgRounding::Nearest,
            )
            .unwrap();
        assert!(none.is_none());
        assert!(s.has_pending(0));
        let (_, none) = s
            .upload(0, 1, Arc::from(vec![1i64, 1]), 2, FedAvgRounding::Nearest)
            .unwrap();
        assert!(none.is_none());
        assert_eq!(s.duplicates, 1, "the second upload of a round is refused");
        let (e, members) = s
            .upload(2, 3, Arc::from(vec![2i64, 2]), 2, FedAvgRounding::Nearest)
            .unwrap();
        // (1 * 10 + 3 * 2) / 4 = 4; (1 * -10 + 3 * 2) / 4 = -1.
        assert_eq!(&s.weights[..], &[4, -1]);
        assert_eq!(s.round, 1);
        assert_eq!(members.unwrap().len(), 2);
        assert_eq!(e.id.clock, 1);
        assert_eq!(s.pending().len(), 0);
        assert_eq!(s.previous.as_deref(), Some(&[0i64, 0][..]));
        assert!(!s.has_pending(0));
    }
}

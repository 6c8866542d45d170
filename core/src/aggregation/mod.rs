//! The baselines against which the chain is measured (`learn.aggregation`): how a robot's
//! trained model becomes the model it starts its next training from, when no blockchain is
//! involved.
//!
//! - `gossip` ([`gossip`]): Flow-FL (Majcherczyk, Srishankar, Pinciroli, ICRA 2021). Each robot
//!   writes its trained model and sample count into a virtual-stigmergy store replicated by
//!   neighbour gossip. At each learning phase a robot *merges* (the [`merge`] rule below).
//! - `central` ([`central`]): an ideal server that gets every upload instantly and aggregates
//!   FedAvg over the contract's quorum.
//! - `matched` ([`matched`]): the matched ideal of the buffered protocol, a server that gets
//!   every update instantly and applies the buffered rule to every `contract.buffer_size` of
//!   them (no delay, staleness bound or outlier check).
//!
//! **The merge rule.** Flow-FL aggregates serverlessly from the gossip-shared structure with
//! FedAvg, each robot contributing a model update when it has collected enough data
//! ("data-driven synchronisation"), and filters nothing. Where the paper leaves the rule open we
//! chose: the store holds one key per robot (its newest model, newest Lamport clock wins); a
//! robot's starting model is the sample-weighted FedAvg (integer, as the contract's) of the
//! newest entry of every key it holds, its own included, once it holds entries from at least
//! `max(floor(contract.quorum_fraction * N), 1)` robots (the chain's quorum, so that both average
//! as many models); below that it continues from its own last trained model (from genesis
//! before its first). Entries never expire: a robot met long ago still counts with its last
//! model. With `learn.gossip_outlier_filter` a robot leaves out the entries (other than its
//! own) whose mean absolute distance to its current model exceeds `contract.outlier_threshold`
//! (the contract's test, applied locally); Flow-FL has no such filter, so it is off by default.
//!
//! **Byzantine robots** run the same attacks (`byzantine.kind`) as on the chain: the driver
//! gives their agent a [`crate::byzantine::View`] whose contract state is built by
//! [`AggregationState::attacker_view`] from what the robot holds (its replica, or the server),
//! and writes or uploads what the attack returns. What acts only on a chain (ledger attacks,
//! robust rules, the EVM, crashes, clock skews, the sealer partition) is refused by
//! [`crate::config::Config::validate`] (`config/validate.rs`).
//!
//! **Faults.** The stigmergy's gossip runs over the radio's peer sets with the `[faults]`
//! partitions (`split`, `isolate`) cut out, and with their loss bursts and delays, as the
//! ledger's gossip does; the ideal server is off the radio.
//!
//! Events ([`AggregationEvent`]) carry every model, so replay never trains; the reduced state
//! ([`AggregationState`]) holds the replicas, the server, each robot's current model and every
//! aggregation, which `summarise` turns into the same figures as the chain's: loss per
//! aggregation, held-out loss, bytes sent and stored per robot. There are no tokens: token
//! conservation does not apply and the summary says so.

pub mod central;
pub mod gossip;
pub mod matched;
pub mod summary;

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::config::{Aggregation, Config, FedAvgRounding};
use crate::contract::{payout, ContractParams, ContractState, Submission, Verdict};
use crate::types::{Digest, RobotId, SimTime};

pub use central::Server;
pub use gossip::{Entry, EntryId, Gossiper, Stigmergy};
pub use matched::MatchedServer;
pub use summary::AggregationSummary;

/// An event of a baseline aggregation (a `chain` run has none).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum AggregationEvent {
    /// `gossip`: `robot` writes its model (trained or forged) under its own key.
    Write {
        /// The writer.
        robot: RobotId,
        /// Samples it claims.
        samples: u64,
        /// The model, fixed point.
        weights: Arc<[i64]>,
    },
    /// `robot` starts a learning phase: `gossip`, it merges the entries it holds into its
    /// starting model; `central`, it downloads the server's model.
    Merge {
        /// The robot.
        robot: RobotId,
    },
    /// `gossip`: `from` sends `entries` to `to` in one message; a `lost` message never arrives.
    /// Messages are numbered by the order of their `Send` events, from 0.
    Send {
        /// Sender.
        from: RobotId,
        /// Receiver.
        to: RobotId,
        /// The versions sent (the sender holds them).
        entries: Vec<EntryId>,
        /// The radio lost it.
        lost: bool,
    },
    /// `gossip`: message number `message` arrives.
    Deliver {
        /// The message's number.
        message: u64,
    },
    /// `central`: `robot` uploads its model to the server.
    Upload {
        /// The robot.
        robot: RobotId,
        /// Samples it claims.
        samples: u64,
        /// The model, fixed point.
        weights: Arc<[i64]>,
    },
}

impl AggregationEvent {
    /// A short name of the event's kind.
    pub fn kind(&self) -> &'static str {
        match self {
            AggregationEvent::Write { .. } => "stigmergy-write",
            AggregationEvent::Merge { .. } => "merge",
            AggregationEvent::Send { .. } => "stigmergy-send",
            AggregationEvent::Deliver { .. } => "stigmergy-deliver",
            AggregationEvent::Upload { .. } => "upload",
        }
    }
}

/// One aggregation: a robot's merge from a quorum (`gossip`) or a server round (`central`).
#[derive(Clone, Debug, PartialEq)]
pub struct AggregationRecord {
    /// When.
    pub time: SimTime,
    /// The merging robot (None: the server).
    pub robot: Option<RobotId>,
    /// The models averaged, by their entry hash (the `tx` of their learning reports).
    pub models: Vec<Digest>,
    /// The result.
    pub weights: Arc<[i64]>,
}

/// What a robot starts its learning phase from, in a baseline.
#[derive(Clone, Debug)]
pub struct StartView {
    /// The starting model.
    pub weights: Arc<[i64]>,
    /// Its digest.
    pub digest: Digest,
    /// Aggregations behind it (`central`: the server's round; `gossip`: the robot's merges
    /// from a quorum).
    pub round: u64,
    /// The model before it (the smart attack's w(t - 1)).
    pub previous: Option<Arc<[i64]>>,
}

/// The digest of a fixed-point model.
pub fn weights_digest(weights: &[i64]) -> Digest {
    let mut h = blake3::Hasher::new();
    for w in weights {
        h.update(&w.to_le_bytes());
    }
    h.finalize().into()
}

/// The merge rule (module docs): the starting model of a robot whose current model is
/// `current`, holding `held` (newest entry per key, its own among them when it has written),
/// or None to keep `own` (its last trained model) or `current`. Returns the model and the
/// hashes of the entries averaged.
pub fn merge(
    robot: RobotId,
    current: &[i64],
    held: &[&Arc<Entry>],
    quorum: usize,
    outlier_units: Option<u64>,
    rounding: FedAvgRounding,
) -> Option<(Vec<i64>, Vec<Digest>)> {
    let kept: Vec<&Arc<Entry>> = held
        .iter()
        .copied()
        .filter(|e| e.weights.len() == current.len())
        .filter(|e| match outlier_units {
            Some(limit) if e.id.key != robot => {
                payout::distance_units(&e.weights, current) <= limit
            }
            _ => true,
        })
        .collect();
    if kept.len() < quorum.max(1) {
        return None;
    }
    let models: Vec<(&[i64], u64)> = kept.iter().map(|e| (&e.weights[..], e.samples)).collect();
    Some((
        payout::fedavg(&models, rounding),
        kept.iter().map(|e| e.hash).collect(),
    ))
}

/// The reduced state of a baseline aggregation.
#[derive(Clone, Debug)]
pub struct AggregationState {
    kind: Aggregation,
    genesis: Arc<[i64]>,
    quorum: usize,
    outlier_units: Option<u64>,
    rounding: FedAvgRounding,
    /// `gossip`: every replica of the store.
    pub stigmergy: Stigmergy,
    /// `central`: the server.
    pub server: Server,
    /// `matched`: the matched ideal's server.
    pub matched: MatchedServer,
    /// Per robot: its current starting model and digest.
    models: Vec<(Arc<[i64]>, Digest)>,
    previous: Vec<Option<Arc<[i64]>>>,
    merges: Vec<u64>,
    /// Every aggregation, in time order.
    pub aggregations: Vec<AggregationRecord>,
    /// Bytes each robot put on the radio (gossip sends, lost ones included; uploads).
    pub bytes_sent: Vec<u64>,
    /// `central`: bytes each robot downloaded from the server.
    pub bytes_downloaded: Vec<u64>,
    digest: Digest,
}

impl AggregationState {
    /// The state at genesis: every robot holds `genesis`.
    pub fn new(config: &Config, genesis: Arc<[i64]>) -> AggregationState {
        let robots = config.world.robots;
        let n = robots as usize;
        let quorum =
            ((config.contract.quorum_fraction * f64::from(robots)).floor() as usize).max(1);
        let outlier_units = config.learn.gossip_outlier_filter.then(|| {
            (config.contract.outlier_threshold
                * config.contract.weight_scale as f64
                * genesis.len() as f64)
                .floor() as u64
        });
        let digest = weights_digest(&genesis);
        AggregationState {
            kind: config.learn.aggregation,
            genesis: genesis.clone(),
            quorum,
            outlier_units,
            rounding: config.contract.fedavg_rounding,
            stigmergy: Stigmergy::new(robots),
            server: Server::new(genesis.clone(), robots),
            matched: MatchedServer::new(config, genesis.clone()),
            models: vec![(genesis, digest); n],
            previous: vec![None; n],
            merges: vec![0; n],
            aggregations: Vec::new(),
            bytes_sent: vec![0; n],
            bytes_downloaded: vec![0; n],
            digest: Digest([0; 32]),
        }
    }

    /// The aggregation this state runs.
    pub fn kind(&self) -> Aggregation {
        self.kind
    }

    /// The genesis model.
    pub fn genesis(&self) -> &[i64] {
        &self.genesis
    }

    /// Models a quorum needs.
    pub fn quorum(&self) -> usize {
        self.quorum
    }

    /// What `robot` would start from if its phase began now (a merge or a download now).
    pub fn preview(&self, robot: RobotId) -> StartView {
        let i = robot as usize;
        match self.kind {
            Aggregation::Central => StartView {
                digest: weights_digest(&self.server.weights),
                weights: self.server.weights.clone(),
                round: self.server.round,
                previous: self.server.previous.clone(),
            },
            Aggregation::Matched => StartView {
                digest: weights_digest(&self.matched.weights),
                weights: self.matched.weights.clone(),
                round: self.matched.version,
                previous: self.matched.previous.clone(),
            },
            _ => {
                let (weights, round) = match self.merged(robot) {
                    Some((w, _)) => (Arc::from(w), self.merges[i] + 1),
                    None => (self.fallback(robot), self.merges[i]),
                };
                StartView {
                    digest: weights_digest(&weights),
                    weights,
                    round,
                    previous: Some(self.models[i].0.clone()),
                }
            }
        }
    }

    /// What `robot` starts from after its `Merge` event.
    pub fn current(&self, robot: RobotId) -> StartView {
        let i = robot as usize;
        match self.kind {
            Aggregation::Central | Aggregation::Matched => self.preview(robot),
            _ => StartView {
                weights: self.models[i].0.clone(),
                digest: self.models[i].1,
                round: self.merges[i],
                previous: self.previous[i].clone(),
            },
        }
    }

    /// The current model of every robot (`central`: the server's for all).
    pub fn models(&self) -> Vec<Arc<[i64]>> {
        (0..self.models.len() as RobotId)
            .map(|r| self.current(r).weights)
            .collect()
    }

    fn merged(&self, robot: RobotId) -> Option<(Vec<i64>, Vec<Digest>)> {
        let held = self.stigmergy.held(robot);
        merge(
            robot,
            &self.models[robot as usize].0,
            &held,
            self.quorum,
            self.outlier_units,
            self.rounding,
        )
    }

    /// Below the quorum: the robot's own newest entry, else its current model.
    fn fallback(&self, robot: RobotId) -> Arc<[i64]> {
        self.stigmergy
            .held(robot)
            .into_iter()
            .find(|e| e.id.key == robot)
            .map_or_else(
                || self.models[robot as usize].0.clone(),
                |e| e.weights.clone(),
            )
    }

    /// What a Byzantine `robot` knows, in the shape of the contract state its attack reads on
    /// the chain (`byzantine::View::chain`), so that every attack runs unchanged:
    /// - `weights`, `round`, `previous_weights`: the model it starts from now (after its
    ///   merge; `central`: the server's) and the one before it;
    /// - `submissions`, the models of others it can read: `gossip`, the newest entry of every
    ///   other key in its own replica (what its stigmergy holds, stale or not); `central`, the
    ///   open round's uploads. A real server would hide them: this is the omniscient attacker
    ///   of the Byzantine-robust FL literature (ALIE, IPM, min-max), the strongest case.
    ///
    /// Each is marked accepted (no contract judges it) with its distance to the starting model.
    /// No tokens: balances are the genesis ones and nothing is staked.
    pub fn attacker_view(&self, robot: RobotId, params: &ContractParams) -> ContractState {
        let start = self.current(robot);
        let others: Vec<(RobotId, u64, Arc<[i64]>)> = match self.kind {
            Aggregation::Central => self
                .server
                .pending()
                .iter()
                .filter(|(r, _)| *r != robot)
                .map(|(r, e)| (*r, e.samples, e.weights.clone()))
                .collect(),
            Aggregation::Matched => self
                .matched
                .pending()
                .filter(|(r, _)| *r != robot)
                .map(|(r, e)| (r, e.samples, e.weights.clone()))
                .collect(),
            _ => self
                .stigmergy
                .held(robot)
                .into_iter()
                .filter(|e| e.id.key != robot)
                .map(|e| (e.id.key, e.samples, e.weights.clone()))
                .collect(),
        };
        let mut view = ContractState::genesis(params);
        view.submissions = others
            .into_iter()
            .filter(|(_, _, w)| w.len() == start.weights.len())
            .map(|(sender, samples, weights)| Submission {
                sender,
                samples,
                distance_units: payout::distance_units(&weights, &start.weights),
                stake_units: 0,
                verdict: Verdict::Accepted,
                weights_digest: crate::contract::model_digest(&weights),
                weights,
            })
            .collect();
        view.round = start.round;
        view.weights_digest = crate::contract::model_digest(&start.weights);
        view.weights = start.weights;
        view.previous_digest = start
            .previous
            .as_ref()
            .map_or_else(Digest::default, |w| crate::contract::model_digest(w));
        view.previous_weights = start.previous;
        view
    }

    /// The hash `robot`'s next model gets in its learning report (the entry it will write or
    /// upload).
    pub fn next_hash(&self, robot: RobotId, samples: u64, weights: Arc<[i64]>) -> Digest {
        match self.kind {
            Aggregation::Central => self.server.next_entry(robot, samples, weights).hash,
            Aggregation::Matched => self.matched.next_entry(robot, samples, weights).hash,
            _ => Entry::new(self.stigmergy.next_id(robot), samples, weights).hash,
        }
    }

    /// The event that submits `robot`'s model in this aggregation.
    pub fn submission(
        &self,
        robot: RobotId,
        samples: u64,
        weights: Arc<[i64]>,
    ) -> AggregationEvent {
        match self.kind {
            Aggregation::Central | Aggregation::Matched => AggregationEvent::Upload {
                robot,
                samples,
                weights,
            },
            _ => AggregationEvent::Write {
                robot,
                samples,
                weights,
            },
        }
    }

    /// Folds one event (the reducer).
    pub fn apply(&mut self, time: SimTime, event: &AggregationEvent) -> Result<(), String> {
        let robots = self.models.len();
        let server = matches!(self.kind, Aggregation::Central | Aggregation::Matched);
        let fits = match event {
            AggregationEvent::Upload { .. } => server,
            AggregationEvent::Merge { .. } => self.kind != Aggregation::Chain,
            _ => self.kind == Aggregation::Gossip,
        };
        if !fits {
            return Err(format!(
                "a {} event in a run whose aggregation is {}",
                event.kind(),
                self.kind.name()
            ));
        }
        match event {
            AggregationEvent::Write {
                robot,
                samples,
                weights,
            } => {
                if weights.len() != self.models[0].0.len() {
                    return Err(format!("robot {robot} writes {} weights", weights.len()));
                }
                self.stigmergy.write(*robot, *samples, weights.clone())?;
            }
            AggregationEvent::Send {
                from,
                to,
                entries,
                lost,
            } => {
                let bytes = self.stigmergy.send(*from, *to, entries, *lost)?;
                self.bytes_sent[*from as usize] += bytes;
            }
            AggregationEvent::Deliver { message } => self.stigmergy.deliver(*message)?,
            AggregationEvent::Upload {
                robot,
                samples,
                weights,
            } => {
                let (entry, members, now) = if self.kind == Aggregation::Matched {
                    let (e, m) = self
                        .matched
                        .upload(time, *robot, *samples, weights.clone())?;
                    (e, m, self.matched.weights.clone())
                } else {
                    let (e, m) = self.server.upload(
                        *robot,
                        *samples,
                        weights.clone(),
                        self.quorum,
                        self.rounding,
                    )?;
                    (e, m, self.server.weights.clone())
                };
                self.bytes_sent[*robot as usize] += entry.bytes;
                if let Some(models) = members {
                    self.aggregations.push(AggregationRecord {
                        time,
                        robot: None,
                        models,
                        weights: now,
                    });
                }
            }
            AggregationEvent::Merge { robot } => {
                let i = *robot as usize;
                if i >= robots {
                    return Err(format!("robot {robot} in a swarm of {robots}"));
                }
                if server {
                    let shared = match self.kind {
                        Aggregation::Matched => {
                            self.matched.download(*robot)?;
                            self.matched.weights.clone()
                        }
                        _ => self.server.weights.clone(),
                    };
                    let entry = Entry::new(
                        EntryId {
                            key: *robot,
                            clock: 0,
                        },
                        1,
                        shared,
                    );
                    self.bytes_downloaded[i] += entry.bytes;
                } else {
                    let next = match self.merged(*robot) {
                        Some((weights, models)) => {
                            let weights: Arc<[i64]> = Arc::from(weights);
                            self.merges[i] += 1;
                            self.aggregations.push(AggregationRecord {
                                time,
                                robot: Some(*robot),
                                models,
                                weights: weights.clone(),
                            });
                            weights
                        }
                        None => self.fallback(*robot),
                    };
                    let digest = weights_digest(&next);
                    let old = std::mem::replace(&mut self.models[i], (next, digest));
                    self.previous[i] = Some(old.0);
                }
            }
        }
        let mut h = blake3::Hasher::new();
        h.update(&self.digest.0);
        h.update(&rmp_serde::to_vec(&(time, event)).expect("aggregation events encode"));
        self.digest = h.finalize().into();
        Ok(())
    }

    /// Digest of the state: every event folded so far (a running hash, as the metrics'), the
    /// replicas and the server.
    pub fn digest(&self) -> Digest {
        let mut h = blake3::Hasher::new();
        h.update(&self.digest.0);
        self.stigmergy.digest_into(&mut h);
        self.server.digest_into(&mut h);
        if self.kind == Aggregation::Matched {
            self.matched.digest_into(&mut h);
        }
        for (_, d) in &self.models {
            h.update(&d.0);
        }
        h.finalize().into()
    }

    /// Bytes each robot stores for aggregation at the end: `gossip`, the entries of its
    /// replica; `central`, its own current model (the server holds the rest).
    pub fn stored_bytes(&self) -> Vec<u64> {
        (0..self.models.len() as RobotId)
            .map(|r| match self.kind {
                Aggregation::Central => {
                    Entry::new(EntryId { key: r, clock: 0 }, 1, self.server.weights.clone()).bytes
                }
                Aggregation::Matched => {
                    Entry::new(
                        EntryId { key: r, clock: 0 },
                        1,
                        self.matched.weights.clone(),
                    )
                    .bytes
                }
                _ => self.stigmergy.stored_bytes(r),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests;

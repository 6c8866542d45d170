//! Flow-FL's shared memory: a virtual-stigmergy store (Pinciroli, Lee, Beltrame 2016), one
//! replica per robot, kept in sync by neighbour gossip over the same radio graph, bandwidth and
//! packet loss as the ledger.
//!
//! The store maps a key to a versioned value. Here a key is a robot's id and the value is the
//! last model that robot trained, with its sample count: each robot writes only its own key,
//! so a key's Lamport clock is its writer's count of writes, and "newest wins" is "greater
//! clock wins". [`Stigmergy`] is the reduced state (every replica, the messages in flight);
//! [`Gossiper`] is the driver side that decides the sends, with the radio's rules
//! ([`crate::radio`], shared with the ledger's gossip): every gossip round (`run.tick_s`),
//! each robot `a` in id order sends each peer `b` in ascending order, in one message, the
//! entries whose version `a` holds newer than `b` (and not already in flight to `b`); a
//! message takes `ceil(bytes * 1000 / bandwidth)` ms after its directed link is free (1 ms
//! with unlimited bandwidth) and is lost with `ledger.packet_loss`, drawn per message from
//! `a`'s `Purpose::Stigmergy` stream. The radio faults act as on the ledger's gossip:
//! partitions (`split`, `isolate`) through the peer sets the driver passes, loss bursts raise
//! the loss and delays add to the airtime of a message sent in their window (`faults.rs`).

use std::collections::BTreeMap;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::AggregationEvent;
use crate::config::Config;
use crate::radio::{Delivery, Message, Radio};
use crate::rng::Purpose;
use crate::types::{Digest, RobotId, SimTime};

/// One version of a key: the key (its writer) and the writer's Lamport clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct EntryId {
    /// The key: the robot whose model this is.
    pub key: RobotId,
    /// Its version (1 for the first write).
    pub clock: u64,
}

/// A stored model.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// Key and version.
    pub id: EntryId,
    /// Training samples the writer claims.
    pub samples: u64,
    /// The model, fixed point (as on chain).
    pub weights: Arc<[i64]>,
    /// Digest of (id, samples, weights): the model's identity in learning reports.
    pub hash: Digest,
    /// Encoded size as it travels and is stored, bytes.
    pub bytes: u64,
}

impl Entry {
    /// The entry `id` holding `weights` and `samples`.
    pub fn new(id: EntryId, samples: u64, weights: Arc<[i64]>) -> Entry {
        let encoded =
            rmp_serde::to_vec(&(id, samples, &weights[..])).expect("stigmergy entries encode");
        Entry {
            id,
            samples,
            hash: Digest(*blake3::hash(&encoded).as_bytes()),
            bytes: encoded.len() as u64,
            weights,
        }
    }
}

#[derive(Clone, Debug)]
struct Flight {
    from: RobotId,
    to: RobotId,
    entries: Vec<EntryId>,
}

/// Every robot's replica of the store and the messages in flight (reduced state).
#[derive(Clone, Debug, Default)]
pub struct Stigmergy {
    /// Every version ever written (content-addressed by id).
    entries: BTreeMap<EntryId, Arc<Entry>>,
    /// Per robot: key -> the clock of the newest version it holds.
    stores: Vec<BTreeMap<RobotId, u64>>,
    /// Per robot: bumped whenever its replica changes (the gossiper's idle cache).
    versions: Vec<u64>,
    flights: BTreeMap<u64, Flight>,
    messages_sent: u64,
    /// Messages the radio lost.
    pub messages_lost: u64,
    /// Bytes received per robot (delivered messages).
    pub bytes_received: Vec<u64>,
}

impl Stigmergy {
    /// Empty replicas for `robots` robots.
    pub fn new(robots: u32) -> Stigmergy {
        Stigmergy {
            stores: vec![BTreeMap::new(); robots as usize],
            versions: vec![0; robots as usize],
            bytes_received: vec![0; robots as usize],
            ..Stigmergy::default()
        }
    }

    fn check_robot(&self, r: RobotId) -> Result<usize, String> {
        let i = r as usize;
        if i < self.stores.len() {
            Ok(i)
        } else {
            Err(format!("robot {r} in a swarm of {}", self.stores.len()))
        }
    }

    /// The id `robot`'s next write will get.
    pub fn next_id(&self, robot: RobotId) -> EntryId {
        let clock = self
            .stores
            .get(robot as usize)
            .and_then(|s| s.get(&robot))
            .map_or(1, |c| c + 1);
        EntryId { key: robot, clock }
    }

    /// Folds a write: `robot` stores a new version of its own key.
    pub fn write(
        &mut self,
        robot: RobotId,
        samples: u64,
        weights: Arc<[i64]>,
    ) -> Result<Arc<Entry>, String> {
        let i = self.check_robot(robot)?;
        if samples == 0 {
            return Err(format!("robot {robot} writes a model of 0 samples"));
        }
        let id = self.next_id(robot);
        let entry = Arc::new(Entry::new(id, samples, weights));
        self.entries.insert(id, entry.clone());
        self.stores[i].insert(robot, id.clock);
        self.versions[i] += 1;
        Ok(entry)
    }

    /// Folds a send; returns its size in bytes.
    pub fn send(
        &mut self,
        from: RobotId,
        to: RobotId,
        entries: &[EntryId],
        lost: bool,
    ) -> Result<u64, String> {
        let a = self.check_robot(from)?;
        self.check_robot(to)?;
        if from == to || entries.is_empty() {
            return Err(format!(
                "robot {from} sends {} entries to {to}",
                entries.len()
            ));
        }
        let mut bytes = 0;
        for id in entries {
            let held = self.stores[a].get(&id.key).copied().unwrap_or(0);
            if held < id.clock {
                return Err(format!(
                    "robot {from} sends version {} of key {} but holds version {held}",
                    id.clock, id.key
                ));
            }
            bytes += self.entries.get(id).map_or(0, |e| e.bytes);
        }
        let seq = self.messages_sent;
        self.messages_sent += 1;
        if lost {
            self.messages_lost += 1;
        } else {
            self.flights.insert(
                seq,
                Flight {
                    from,
                    to,
                    entries: entries.to_vec(),
                },
            );
        }
        Ok(bytes)
    }

    /// Folds a delivery: the receiver keeps each entry that is newer than its own version.
    pub fn deliver(&mut self, message: u64) -> Result<(), String> {
        let flight = self
            .flights
            .remove(&message)
            .ok_or_else(|| format!("message {message} is not in flight"))?;
        let b = flight.to as usize;
        let mut changed = false;
        for id in &flight.entries {
            let entry = self.entries.get(id).expect("sent entries are stored");
            self.bytes_received[b] += entry.bytes;
            let held = self.stores[b].entry(id.key).or_insert(0);
            if *held < id.clock {
                *held = id.clock;
                changed = true;
            }
        }
        if changed {
            self.versions[b] += 1;
        }
        debug_assert!(flight.from != flight.to);
        Ok(())
    }

    /// The newest entries `robot` holds, in key order.
    pub fn held(&self, robot: RobotId) -> Vec<&Arc<Entry>> {
        self.stores
            .get(robot as usize)
            .map(|s| {
                s.iter()
                    .map(|(&key, &clock)| {
                        self.entries
                            .get(&EntryId { key, clock })
                            .expect("held versions are stored")
                    })
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Bytes of the entries `robot` holds.
    pub fn stored_bytes(&self, robot: RobotId) -> u64 {
        self.held(robot).iter().map(|e| e.bytes).sum()
    }

    /// Messages sent so far (the next message's number).
    pub fn messages_sent(&self) -> u64 {
        self.messages_sent
    }

    fn version(&self, robot: RobotId) -> u64 {
        self.versions[robot as usize]
    }

    fn clock_held(&self, robot: RobotId, key: RobotId) -> u64 {
        self.stores[robot as usize].get(&key).copied().unwrap_or(0)
    }

    fn entry_bytes(&self, id: &EntryId) -> u64 {
        self.entries.get(id).map_or(0, |e| e.bytes)
    }

    /// Digest of every replica (the keys and versions each robot holds) and the messages in
    /// flight.
    pub fn digest_into(&self, h: &mut blake3::Hasher) {
        for store in &self.stores {
            h.update(&(store.len() as u64).to_le_bytes());
            for (key, clock) in store {
                h.update(&key.to_le_bytes());
                h.update(&clock.to_le_bytes());
            }
        }
        h.update(&self.messages_sent.to_le_bytes());
        for (seq, f) in &self.flights {
            h.update(&seq.to_le_bytes());
            h.update(&f.to.to_le_bytes());
        }
    }
}

/// The driver side of the stigmergy's gossip: which send or delivery comes next.
#[derive(Clone, Debug)]
pub struct Gossiper {
    robots: u32,
    /// The gossip rounds, links and messages in flight.
    radio: Radio<EntryId>,
    /// Per ordered pair, the replica versions last found with nothing to send.
    idle: Vec<Option<(u64, u64)>>,
}

impl Gossiper {
    /// The gossip scheduler of a run.
    pub fn new(config: &Config, seed: u64) -> Gossiper {
        let robots = config.world.robots;
        Gossiper {
            robots,
            radio: Radio::new(config, seed, Purpose::Stigmergy),
            idle: vec![None; (robots as usize) * (robots as usize)],
        }
    }

    /// The next send or delivery due at or before `until`, or None. `peers[a]` lists the robots
    /// `a` can reach now. The driver must apply every returned event before asking again.
    pub fn next_event(
        &mut self,
        store: &Stigmergy,
        until: SimTime,
        peers: &[Vec<RobotId>],
    ) -> Option<(SimTime, AggregationEvent)> {
        self.radio.check_applied(store.messages_sent());
        loop {
            // A delivery comes before a send at the same time.
            let gossip_time = self.radio.gossip_time();
            let delivery = self
                .radio
                .next_delivery()
                .filter(|&(t, _)| t <= gossip_time);
            if delivery.map_or(gossip_time, |(t, _)| t) > until {
                return None;
            }
            if delivery.is_some() {
                let Delivery { at, message, .. } =
                    self.radio.pop_delivery().expect("a delivery is due");
                return Some((at, AggregationEvent::Deliver { message }));
            }
            if self.radio.open_round() {
                self.gossip_round(store, peers);
            }
            let bytes = |id: &EntryId| store.entry_bytes(id);
            let Some(send) = self.radio.take_send(store.messages_sent(), bytes) else {
                continue;
            };
            let event = AggregationEvent::Send {
                from: send.from,
                to: send.to,
                entries: send.items,
                lost: send.lost,
            };
            return Some((self.radio.batch_time(), event));
        }
    }

    /// Computes the sends of one gossip round (the radio's round just opened).
    fn gossip_round(&mut self, store: &Stigmergy, peers: &[Vec<RobotId>]) {
        let n = self.robots as usize;
        for a in 0..self.robots {
            let Some(list) = peers.get(a as usize) else {
                continue;
            };
            let mut list: Vec<RobotId> = list
                .iter()
                .copied()
                .filter(|&b| b != a && b < self.robots)
                .collect();
            list.sort_unstable();
            list.dedup();
            for b in list {
                let versions = (store.version(a), store.version(b));
                let slot = a as usize * n + b as usize;
                if self.idle[slot] == Some(versions) {
                    continue;
                }
                let entries: Vec<EntryId> = store.stores[a as usize]
                    .iter()
                    .map(|(&key, &clock)| EntryId { key, clock })
                    .filter(|id| {
                        store.clock_held(b, id.key) < id.clock && !self.radio.is_in_flight(b, id)
                    })
                    .collect();
                if entries.is_empty() {
                    self.idle[slot] = Some(versions);
                    continue;
                }
                self.idle[slot] = None;
                let lost = self.radio.draw_loss(a);
                self.radio.queue(Message {
                    from: a,
                    to: b,
                    items: entries,
                    lost,
                });
            }
        }
    }
}

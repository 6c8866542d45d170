//! The radio link layer shared by every gossip over the swarm's radio graph: the ledger's
//! ([`crate::ledger::Network`]) and the gossip baseline's
//! ([`crate::aggregation::gossip::Gossiper`]).
//!
//! [`Radio`] is driver-side state, never part of a reduced state: it schedules the messages
//! a gossip protocol decides to send, and hands them back in order. What goes in a message
//! is the protocol's business; when it leaves, when it arrives and whether it is lost is the
//! radio's, by the same rules for both protocols (all in integer simulated milliseconds):
//! - *Rounds*: every `run.tick_s` the protocol computes one round of sends, queued in the
//!   order computed; they all leave at the round's time, one per poll.
//! - *Loss*: drawn per message, in send order, from the sender's own stream (the protocol's
//!   [`Purpose`]), with `ledger.packet_loss` raised by the fault schedule's loss bursts.
//! - *Airtime*: a message arrives [`airtime_ms`] after its directed link is free (FIFO per
//!   link), plus the fault schedule's extra delay at its send time.
//! - *Flights*: messages in flight are keyed (delivery time, receiver, number), so that
//!   simultaneous deliveries come in receiver order, then send order; while in flight to a
//!   receiver, an item is marked so that the protocol does not send it there again.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use crate::config::Config;
use crate::faults::FaultSchedule;
use crate::rng::{self, Purpose, Rng};
use crate::types::{RobotId, SimTime};

/// The time a message of `bytes` bytes takes on a link of `bandwidth_bytes_per_s`:
/// `ceil(bytes * 1000 / bandwidth)` ms, at least 1 ms; 1 ms with unlimited bandwidth (0), so
/// that a message still arrives after it is sent.
pub fn airtime_ms(bytes: u64, bandwidth_bytes_per_s: u64) -> u64 {
    if bandwidth_bytes_per_s == 0 {
        1
    } else {
        (bytes * 1000).div_ceil(bandwidth_bytes_per_s).max(1)
    }
}

/// A message of a gossip round: `from` sends `items` to `to`; a `lost` one never arrives.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Message<K> {
    /// Sender.
    pub from: RobotId,
    /// Receiver.
    pub to: RobotId,
    /// What the message carries, as the protocol names it.
    pub items: Vec<K>,
    /// The radio lost it.
    pub lost: bool,
}

/// A message whose delivery time has come.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Delivery {
    /// The delivery time.
    pub at: SimTime,
    /// The receiver.
    pub to: RobotId,
    /// The message's number (the protocol's count of sends when it was sent).
    pub message: u64,
}

/// The gossip rounds, the links and the messages in flight of one gossip protocol, whose
/// messages carry items of type `K`.
#[derive(Clone, Debug)]
pub struct Radio<K> {
    robots: u32,
    gossip_ms: u64,
    bandwidth_bytes_per_s: u64,
    packet_loss: f64,
    faults: FaultSchedule,
    loss_rngs: Vec<Rng>,
    next_gossip: SimTime,
    /// Sends of the current gossip round, to be returned at `batch_time`.
    batch: VecDeque<Message<K>>,
    batch_time: SimTime,
    /// Messages in flight by (delivery time, receiver, number): their items.
    flights: BTreeMap<(SimTime, RobotId, u64), Vec<K>>,
    in_flight: BTreeSet<(RobotId, K)>,
    /// Per directed link, when it is free again (entries in the past are dropped: a free
    /// link and a missing one are the same).
    link_free: BTreeMap<(RobotId, RobotId), SimTime>,
    /// The number the last returned send will get once applied.
    awaiting_send: Option<u64>,
}

impl<K: Copy + Ord> Radio<K> {
    /// The radio of a run; each robot's losses are drawn from its `purpose` stream.
    pub fn new(config: &Config, seed: u64, purpose: Purpose) -> Radio<K> {
        let robots = config.world.robots;
        Radio {
            robots,
            gossip_ms: ((config.run.tick_s * 1000.0).round() as u64).max(1),
            bandwidth_bytes_per_s: config.ledger.bandwidth_bytes_per_s,
            packet_loss: config.ledger.packet_loss,
            faults: FaultSchedule::new(&config.faults, robots),
            loss_rngs: (0..robots).map(|r| rng::stream(seed, purpose, r)).collect(),
            next_gossip: SimTime(0),
            batch: VecDeque::new(),
            batch_time: SimTime(0),
            flights: BTreeMap::new(),
            in_flight: BTreeSet::new(),
            link_free: BTreeMap::new(),
            awaiting_send: None,
        }
    }

    /// The run's fault schedule.
    pub fn faults(&self) -> &FaultSchedule {
        &self.faults
    }

    /// The time of the current gossip round (its sends leave then).
    pub fn batch_time(&self) -> SimTime {
        self.batch_time
    }

    /// Asserts that the driver applied the last send returned by [`Radio::take_send`]:
    /// `messages_sent` is the protocol's count of sends applied so far.
    pub fn check_applied(&mut self, messages_sent: u64) {
        if let Some(seq) = self.awaiting_send.take() {
            assert!(
                messages_sent > seq,
                "the driver did not apply the last Send before polling"
            );
        }
    }

    /// The earliest delivery due: (time, receiver).
    pub fn next_delivery(&self) -> Option<(SimTime, RobotId)> {
        self.flights.keys().next().map(|&(t, to, _)| (t, to))
    }

    /// When the next send leaves: now, while the current round has sends left, else at the
    /// next round.
    pub fn gossip_time(&self) -> SimTime {
        if self.batch.is_empty() {
            self.next_gossip
        } else {
            self.batch_time
        }
    }

    /// Takes the earliest delivery due; its items are no longer in flight.
    pub fn pop_delivery(&mut self) -> Option<Delivery> {
        let ((at, to, message), items) = self.flights.pop_first()?;
        for item in items {
            self.in_flight.remove(&(to, item));
        }
        Some(Delivery { at, to, message })
    }

    /// Opens the next gossip round if the current one has no sends left, and returns whether
    /// it did: the protocol must then compute the round's sends ([`Radio::queue`]).
    pub fn open_round(&mut self) -> bool {
        if !self.batch.is_empty() {
            return false;
        }
        self.batch_time = self.next_gossip;
        self.next_gossip = SimTime(self.next_gossip.0 + self.gossip_ms);
        // Links free before now are as good as unused.
        if self.link_free.len() > 4 * self.robots as usize {
            let now = self.batch_time;
            self.link_free.retain(|_, free| *free > now);
        }
        true
    }

    /// Whether `item` is in flight to `to`.
    pub fn is_in_flight(&self, to: RobotId, item: &K) -> bool {
        self.in_flight.contains(&(to, *item))
    }

    /// Whether the radio loses the next message `from` sends this round: one draw from the
    /// sender's stream, with the loss probability at the round's time.
    pub fn draw_loss(&mut self, from: RobotId) -> bool {
        let loss = self.faults.loss_at(self.packet_loss, self.batch_time.0);
        self.loss_rngs[from as usize].chance(loss)
    }

    /// Queues a send of this round (after the ones queued before); the items of a message
    /// not lost are in flight from now on.
    pub fn queue(&mut self, message: Message<K>) {
        if !message.lost {
            for item in &message.items {
                self.in_flight.insert((message.to, *item));
            }
        }
        self.batch.push_back(message);
    }

    /// The next send of this round, if any, scheduled on its link: it will be message number
    /// `message` (the protocol's count of sends so far), of `bytes(item)` summed over its
    /// items. It leaves at [`Radio::batch_time`]; the driver must apply it before polling
    /// again (see [`Radio::check_applied`]).
    pub fn take_send(&mut self, message: u64, bytes: impl Fn(&K) -> u64) -> Option<Message<K>> {
        let send = self.batch.pop_front()?;
        self.awaiting_send = Some(message);
        let bytes: u64 = send.items.iter().map(bytes).sum();
        let airtime_ms = airtime_ms(bytes, self.bandwidth_bytes_per_s)
            + self.faults.extra_delay_ms(self.batch_time.0);
        let link = self
            .link_free
            .entry((send.from, send.to))
            .or_insert(SimTime(0));
        let start = (*link).max(self.batch_time);
        let due = SimTime(start.0 + airtime_ms);
        *link = due;
        if !send.lost {
            self.flights
                .insert((due, send.to, message), send.items.clone());
        }
        Some(send)
    }

    /// Takes over at `now` (a forked run): gossip resumes at the first round at or after
    /// `now`, and `flights` (number, receiver, items) are delivered 1 ms after it. The loss
    /// streams and the link queues start afresh.
    pub fn resume(
        &mut self,
        now: SimTime,
        flights: impl IntoIterator<Item = (u64, RobotId, Vec<K>)>,
    ) {
        self.next_gossip = SimTime(now.0.div_ceil(self.gossip_ms) * self.gossip_ms);
        for (message, to, items) in flights {
            for item in &items {
                self.in_flight.insert((to, *item));
            }
            self.flights
                .insert((SimTime(now.0 + 1), to, message), items);
        }
    }

    /// Drops every message in flight to `node` (it restarted) and its links' queues.
    pub fn drop_to(&mut self, node: RobotId) {
        self.flights.retain(|k, _| k.1 != node);
        self.in_flight.retain(|(to, _)| *to != node);
        self.link_free.retain(|(_, to), _| *to != node);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A radio of 4 robots, 1 s rounds, 1000 bytes/s, no loss, with `delays` (extra ms, from
    /// s, to s).
    fn radio(delays: &[(u64, f64, f64)]) -> Radio<u32> {
        let mut config = Config::default();
        config.world.robots = 4;
        config.run.tick_s = 1.0;
        config.ledger.bandwidth_bytes_per_s = 1000;
        config.ledger.packet_loss = 0.0;
        config.faults.delays = delays
            .iter()
            .map(|&(extra_ms, start_s, end_s)| crate::faults::Delay {
                extra_ms,
                start_s,
                end_s,
            })
            .collect();
        Radio::new(&config, 1, Purpose::Network)
    }

    fn send(from: RobotId, to: RobotId, items: &[u32], lost: bool) -> Message<u32> {
        Message {
            from,
            to,
            items: items.to_vec(),
            lost,
        }
    }

    #[test]
    fn airtime_is_the_bytes_over_the_bandwidth_rounded_up_and_at_least_one_ms() {
        for (bytes, bandwidth, expected) in [
            (0, 0, 1),
            (1_000_000, 0, 1),
            (0, 1000, 1),
            (1, 1000, 1),
            (1000, 1000, 1000),
            (1001, 1000, 1001),
            (1500, 2000, 750),
            (1, 3, 334),
        ] {
            assert_eq!(
                airtime_ms(bytes, bandwidth),
                expected,
                "{bytes} B at {bandwidth} B/s"
            );
        }
    }

    #[test]
    fn a_link_sends_one_message_at_a_time_and_links_are_independent() {
        let mut r = radio(&[]);
        assert!(r.open_round());
        assert_eq!(r.batch_time(), SimTime(0));
        r.queue(send(0, 1, &[7], false));
        r.queue(send(0, 1, &[8], false));
        r.queue(send(0, 2, &[9], false));
        assert!(!r.open_round(), "the round still has sends");
        assert!(r.is_in_flight(1, &7) && r.is_in_flight(1, &8) && r.is_in_flight(2, &9));
        // 500 bytes each: 500 ms of airtime; the second message on 0 -> 1 waits for the first.
        for seq in 0..3 {
            let sent = r.take_send(seq, |_| 500).expect("queued");
            r.check_applied(seq + 1);
            assert_eq!(sent.items.len(), 1);
        }
        assert_eq!(r.take_send(3, |_| 500), None);
        let due: Vec<_> = std::iter::from_fn(|| r.pop_delivery()).collect();
        let at = |ms, to, message| Delivery {
            at: SimTime(ms),
            to,
            message,
        };
        assert_eq!(due, vec![at(500, 1, 0), at(500, 2, 2), at(1000, 1, 1)]);
        assert!(!r.is_in_flight(1, &7) && !r.is_in_flight(2, &9));
        // The next round starts a period later, on links that are free again.
        assert!(r.open_round());
        assert_eq!(r.batch_time(), SimTime(1000));
        assert_eq!(r.gossip_time(), SimTime(2000));
    }

    #[test]
    fn a_lost_message_takes_its_airtime_but_is_never_in_flight() {
        let mut r = radio(&[]);
        r.open_round();
        r.queue(send(0, 1, &[7], true));
        r.queue(send(0, 1, &[8], false));
        assert!(!r.is_in_flight(1, &7));
        r.take_send(0, |_| 300);
        r.take_send(1, |_| 300);
        let d = r.pop_delivery().expect("the second message");
        assert_eq!((d.at, d.message), (SimTime(600), 1));
        assert_eq!(r.pop_delivery(), None);
    }

    #[test]
    fn a_delay_window_adds_to_the_airtime_of_messages_sent_in_it() {
        let mut r = radio(&[(250, 0.5, 1.5)]);
        r.open_round();
        r.queue(send(0, 1, &[1], false));
        r.take_send(0, |_| 100);
        r.open_round();
        r.queue(send(0, 1, &[2], false));
        r.take_send(1, |_| 100);
        let due: Vec<_> = std::iter::from_fn(|| r.pop_delivery())
            .map(|d| d.at)
            .collect();
        assert_eq!(due, vec![SimTime(100), SimTime(1000 + 100 + 250)]);
    }

    #[test]
    fn a_restart_drops_the_messages_to_the_node_and_a_resume_delivers_at_once() {
        let mut r = radio(&[]);
        r.open_round();
        r.queue(send(0, 1, &[1], false));
        r.queue(send(0, 2, &[2], false));
        r.take_send(0, |_| 100);
        r.take_send(1, |_| 100);
        r.drop_to(1);
        assert!(!r.is_in_flight(1, &1) && r.is_in_flight(2, &2));
        assert_eq!(r.pop_delivery().map(|d| d.to), Some(2));
        let mut fresh = radio(&[]);
        fresh.resume(SimTime(2500), [(5, 3, vec![4])]);
        assert!(fresh.is_in_flight(3, &4));
        assert_eq!(fresh.gossip_time(), SimTime(3000));
        assert_eq!(
            fresh.pop_delivery(),
            Some(Delivery {
                at: SimTime(2501),
                to: 3,
                message: 5
            })
        );
    }
}

//! The driver side of the ledger: which event comes next.
//!
//! [`Network`] is not part of the reduced state; it decides, from the [`Ledger`]'s state, the
//! peer sets and its own seeded randomness, the next sealing, gossip send or delivery, and
//! returns it as a [`LedgerEvent`] for the driver to log and apply. Replaying a log needs no
//! `Network`.
//!
//! Timing (all in integer simulated milliseconds, independent of how often the network is
//! polled):
//! - *Sealing*: a node may seal on its head at head.timestamp + period (in turn) or that plus a
//!   delay (out of turn), but not before its head was adopted, and not at all while Clique's
//!   recent-signer rule forbids it or once its head's chain removed it from the signer set
//!   (equivocation). A sealing carries the evidence the node holds against sealers still in
//!   the set ([`Ledger::sealable_evidence`]). The out-of-turn delay is uniform in
//!   [0, (N/2 + 1) * wiggle_unit) and is a pure function of (seed, node, parent): keyed blake3
//!   with the key `rng::derive_bytes(seed, Purpose::Sealing, node)`. Being a function of the
//!   parent rather than a position in a stream, it cannot depend on polling or on how many
//!   heads the node went through.
//! - *Gossip*: every `run.tick_s` (the gossip round), for each node `a` in id order and each
//!   peer `b` in ascending order: if `a`'s head is heavier than `b`'s and unknown to `b`, `a`
//!   sends the blocks of its canonical chain that `b` lacks (ancestors first; also for an
//!   equally heavy head when `b` may not seal on its own but may on `a`'s); and `a` sends
//!   the pending transactions `b` has not seen (in `a`'s arrival order). Items already in
//!   flight to `b` are not sent again (so `b` fetches each item from one peer at a time). All
//!   of it goes in one message per (a, b) and round; nothing is sent (and nothing logged) when
//!   there is nothing to send. Packet loss is drawn per message from `a`'s
//!   `Purpose::Network` stream, in send order.
//! - *Delivery* (the rules of [`crate::radio`], shared with the gossip baseline): a message
//!   arrives `ceil(bytes * 1000 / bandwidth)` ms after its link is free (FIFO per directed
//!   link), at least 1 ms after it is sent; with unlimited bandwidth, 1 ms after it is sent,
//!   so one hop per gossip round.
//! - Simultaneous events come in the order (time, kind, node): deliveries, sealings, sends
//!   (see [`LedgerEvent::kind_rank`]).
//! - *Faults* ([`crate::faults`]): a crashed node neither seals nor receives (deliveries due
//!   to it are dropped; its peers are cut by the driver), a loss burst raises the loss
//!   probability of the messages sent in it, a delay window adds latency to them, and a node
//!   with a skewed clock seals when *its* clock reaches the sealing time.
//! - *Withholding* (a Byzantine ledger behaviour): the gossip of a withholding node leaves
//!   out the blocks its policy hides from the receiver (and everything after them).

use std::collections::BTreeSet;
use std::sync::Arc;

use super::{BlockHash, ItemRef, Ledger, LedgerEvent, TxHash};
use crate::config::Config;
use crate::radio::{Delivery, Message, Radio};
use crate::rng::{self, Purpose};
use crate::types::{RobotId, SimTime};

/// The sealings due: each node's sealing time on its current head, and the nodes that are up
/// then, by time. Updated from the ledger's journal of head changes, so a poll looks only at
/// the nodes whose head or head time changed since the last one.
/// A rule by which some nodes' gossip hides blocks from some peers: how a ledger misbehaviour
/// (`byzantine.ledger = "withhold"`, `byzantine/ledger/withhold.rs`) acts on the network. The
/// ledger defines the question and the attack answers it, so the ledger never names an attack.
pub trait GossipFilter: std::fmt::Debug + Send + Sync {
    /// Whether `from`'s gossip hides `block` from `to` at `now`.
    fn hides(
        &self,
        ledger: &Ledger,
        from: RobotId,
        to: RobotId,
        block: &BlockHash,
        now: SimTime,
    ) -> bool;
}

#[derive(Clone, Debug, Default)]
struct SealSchedule {
    /// Per node, its sealing time on its head (None: it may not seal there).
    times: Vec<Option<SimTime>>,
    /// (time, node) for every node with a sealing time at which it is up.
    due: BTreeSet<(SimTime, RobotId)>,
    /// The position of the ledger's head journal read so far (None: nothing read yet).
    journal: Option<u64>,
}

/// What the gossip remembers of an ordered pair (a, b) of peers between rounds. Everything
/// but `idle` is a cache that can be dropped at any time.
#[derive(Clone, Copy, Debug)]
struct PairMemo {
    /// The (a, b) knowledge versions last found with nothing to send: unchanged versions
    /// mean still nothing to send.
    idle: Option<(u64, u64)>,
    /// Every transaction of `a`'s mempool with an arrival number below `cursor` was, when the
    /// pair was last looked at, known to `b`, refused by `b` or in flight to `b`. It stays so
    /// unless `b` forgets it (the ledger logs what each node forgets; `forgets` is the
    /// position in `b`'s log then) or the network drops a message to `b` (`drops` is `b`'s
    /// drop count then): a transaction in flight arrives, and is then known or refused. A
    /// transaction that enters the mempool again gets a new arrival number, above the cursor.
    cursor: u64,
    forgets: u64,
    drops: u64,
    /// The gossip round that last looked at the pair.
    round: u64,
}

/// The driver-side scheduler of sealings, gossip and deliveries.
#[derive(Clone, Debug)]
pub struct Network {
    seed: u64,
    robots: u32,
    wiggle_max_ms: u64,
    /// The gossip rounds, links and messages in flight (and the fault schedule).
    radio: Radio<ItemRef>,
    /// Per sender `a`, what the gossip remembers of each receiver `b` (ascending): pairs out
    /// of range for a while are forgotten when nothing of theirs is still valid, so memory
    /// follows the links, not the square of the swarm.
    pairs: Vec<Vec<(RobotId, PairMemo)>>,
    /// A reusable buffer for a sender's peers.
    peer_buffer: Vec<RobotId>,
    /// Gossip rounds so far.
    rounds: u64,
    /// Per node, the messages in flight to it that the network dropped undelivered (a crashed
    /// receiver, a restart): their items are neither known to it nor in flight any more.
    dropped: Vec<u64>,
    seals: SealSchedule,
    skews_ms: Vec<i64>,
    withhold: Option<Arc<dyn GossipFilter>>,
}

impl Network {
    /// The network of a run.
    pub fn new(config: &Config, seed: u64) -> Network {
        let robots = config.world.robots;
        let l = &config.ledger;
        Network {
            seed,
            robots,
            wiggle_max_ms: (f64::from(robots / 2 + 1) * l.wiggle_unit_s * 1000.0).round() as u64,
            radio: Radio::new(config, seed, Purpose::Network),
            pairs: vec![Vec::new(); robots as usize],
            peer_buffer: Vec::new(),
            rounds: 0,
            dropped: vec![0; robots as usize],
            seals: SealSchedule {
                times: vec![None; robots as usize],
                ..SealSchedule::default()
            },
            skews_ms: config.faults.skews_ms(robots),
            withhold: None,
        }
    }

    /// Makes the gossip hide what `filter` says (a ledger misbehaviour; `None`: honest gossip).
    pub fn set_withhold(&mut self, filter: Option<Arc<dyn GossipFilter>>) {
        self.withhold = filter;
    }

    /// A node restarted: the messages in flight to it are gone (the ledger drops them too).
    pub fn on_restart(&mut self, node: RobotId) {
        self.radio.drop_to(node);
        if let Some(d) = self.dropped.get_mut(node as usize) {
            *d += 1;
        }
    }

    /// A network that takes over a ledger replayed up to some time (a forked run): gossip
    /// resumes at the first round at or after the ledger's time, and the messages in flight
    /// are delivered 1 ms after it. The loss streams and the link queues start afresh, so the
    /// continuation is deterministic but is not the one the original network would have
    /// produced.
    pub fn resume(config: &Config, seed: u64, ledger: &Ledger) -> Network {
        let mut net = Network::new(config, seed);
        let flights = ledger
            .messages_in_flight()
            .into_iter()
            .map(|(seq, _, to, items)| (seq, to, items.to_vec()));
        net.radio.resume(ledger.now(), flights);
        net
    }

    /// The out-of-turn sealing delay of `node` on `parent`, in ms.
    pub fn sealing_delay_ms(&self, node: RobotId, parent: &BlockHash) -> u64 {
        if self.wiggle_max_ms == 0 {
            return 0;
        }
        let key = rng::derive_bytes(self.seed, Purpose::Sealing, node);
        let h = blake3::keyed_hash(&key, &parent.0);
        let x = u64::from_le_bytes(h.as_bytes()[..8].try_into().expect("8 bytes"));
        ((u128::from(x) * u128::from(self.wiggle_max_ms)) >> 64) as u64
    }

    /// When `node` will seal on its current head, if it may: a function of its head, the
    /// time it adopted it and the run's constants only.
    pub fn seal_time(&self, ledger: &Ledger, node: RobotId) -> Option<SimTime> {
        let (head, _) = ledger.head(node);
        let since = ledger.head_since(node);
        if !ledger.may_seal_on(&head, node) {
            // Signed recently, or removed from the signer set for equivocating.
            None
        } else {
            let parent_ms = ledger
                .block(&head)
                .expect("the head is stored")
                .block
                .header
                .timestamp_ms;
            let base = parent_ms + ledger.period_ms();
            let delay = if ledger.expected_difficulty(&head, node) == 2 {
                0
            } else {
                self.sealing_delay_ms(node, &head)
            };
            // The node's clock must read the sealing time (its own stamp), whatever its skew.
            let skew = self.skews_ms.get(node as usize).copied().unwrap_or(0);
            let local = base + delay;
            let true_ms = local.saturating_add_signed(-skew);
            Some(SimTime(true_ms).max(since))
        }
    }

    /// Brings the sealing schedule up to the ledger: the nodes whose head or head time
    /// changed since the last call (all of them the first time, or when the ledger's journal
    /// no longer reaches back to the last call).
    fn update_seals(&mut self, ledger: &Ledger) {
        match self
            .seals
            .journal
            .and_then(|since| ledger.head_changes_since(since))
        {
            Some(nodes) => {
                for node in nodes {
                    self.reschedule(ledger, node);
                }
            }
            None => {
                for node in 0..self.robots {
                    self.reschedule(ledger, node);
                }
            }
        }
        self.seals.journal = Some(ledger.head_journal_end());
    }

    /// Recomputes one node's sealing time and its place among the sealings due.
    fn reschedule(&mut self, ledger: &Ledger, node: RobotId) {
        if let Some(t) = self.seals.times[node as usize].take() {
            self.seals.due.remove(&(t, node));
        }
        let t = self.seal_time(ledger, node);
        self.seals.times[node as usize] = t;
        if let Some(t) = t {
            if !self.radio.faults().is_down(node, t.0) {
                self.seals.due.insert((t, node));
            }
        }
    }

    /// The next sealing: the earliest (time, node) over the nodes that are up at their
    /// sealing time, by a look at every node (tests compare the schedule with it).
    #[cfg(test)]
    fn next_seal_by_scan(&self, ledger: &Ledger) -> Option<(SimTime, RobotId)> {
        (0..self.robots)
            .filter_map(|node| self.seal_time(ledger, node).map(|t| (t, node)))
            .filter(|&(t, node)| !self.radio.faults().is_down(node, t.0))
            .min()
    }

    /// The next event due at or before `until`, or None. `peers[a]` lists the robots `a` can
    /// reach now (the world's peer sets; missing entries mean none). The driver must apply
    /// every returned event to `ledger` before asking again.
    pub fn next_event(
        &mut self,
        ledger: &Ledger,
        until: SimTime,
        peers: &[Vec<RobotId>],
    ) -> Option<(SimTime, LedgerEvent)> {
        self.radio.check_applied(ledger.messages_sent());
        assert_eq!(
            ledger.robots(),
            self.robots,
            "network and ledger disagree on robots"
        );
        // The ledger does not change until this call returns.
        self.update_seals(ledger);
        #[cfg(test)]
        assert_eq!(
            self.seals.due.first().copied(),
            self.next_seal_by_scan(ledger),
            "the sealing schedule differs from a look at every node"
        );
        loop {
            // Candidates as (time, kind rank, node).
            let delivery = self.radio.next_delivery().map(|(t, to)| (t, 0u8, to));
            let seal = self.seals.due.first().map(|&(t, node)| (t, 3u8, node));
            let gossip = Some((self.radio.gossip_time(), 4u8, 0));
            let best = [delivery, seal, gossip]
                .into_iter()
                .flatten()
                .min()
                .expect("gossip is always a candidate");
            if best.0 > until {
                return None;
            }
            match best.1 {
                0 => {
                    let Delivery { at, to, message } =
                        self.radio.pop_delivery().expect("a delivery is due");
                    if self.radio.faults().is_down(to, at.0) {
                        // A crashed receiver: the message is dropped (the ledger forgets it
                        // at the restart).
                        self.dropped[to as usize] += 1;
                        continue;
                    }
                    return Some((at, LedgerEvent::Deliver { message }));
                }
                3 => {
                    let node = best.2;
                    let (parent, _) = ledger.head(node);
                    let txs = ledger.sealable_txs(node);
                    let evidence = ledger.sealable_evidence(node);
                    return Some((
                        best.0,
                        LedgerEvent::Seal {
                            node,
                            parent,
                            txs,
                            evidence,
                        },
                    ));
                }
                _ => {
                    if self.radio.open_round() {
                        self.gossip_round(ledger, peers);
                    }
                    let bytes = |item: &ItemRef| ledger.item_bytes(item);
                    let Some(send) = self.radio.take_send(ledger.messages_sent(), bytes) else {
                        continue;
                    };
                    let event = LedgerEvent::Send {
                        from: send.from,
                        to: send.to,
                        items: send.items,
                        lost: send.lost,
                    };
                    return Some((self.radio.batch_time(), event));
                }
            }
        }
    }

    /// Computes the sends of one gossip round (the radio's round just opened).
    fn gossip_round(&mut self, ledger: &Ledger, peers: &[Vec<RobotId>]) {
        self.rounds += 1;
        let mut list = std::mem::take(&mut self.peer_buffer);
        for a in 0..self.robots {
            let Some(reach) = peers.get(a as usize) else {
                continue;
            };
            list.clear();
            list.extend(reach.iter().copied().filter(|&b| b != a && b < self.robots));
            list.sort_unstable();
            list.dedup();
            for &b in &list {
                self.gossip_pair(ledger, a, b);
            }
            self.forget_pairs(ledger, a, list.len());
        }
        self.peer_buffer = list;
    }

    /// The memory of the pair (a, b), made if missing.
    fn pair_memo(&mut self, ledger: &Ledger, a: RobotId, b: RobotId) -> &mut PairMemo {
        let memos = &mut self.pairs[a as usize];
        let i = match memos.binary_search_by_key(&b, |m| m.0) {
            Ok(i) => i,
            Err(i) => {
                let memo = PairMemo {
                    idle: None,
                    cursor: 0,
                    forgets: ledger.forgotten_txs(b),
                    drops: self.dropped[b as usize],
                    round: 0,
                };
                memos.insert(i, (b, memo));
                i
            }
        };
        &mut memos[i].1
    }

    /// What `a` sends `b` this round, if anything.
    fn gossip_pair(&mut self, ledger: &Ledger, a: RobotId, b: RobotId) {
        let versions = (ledger.node_version(a), ledger.node_version(b));
        let drops = self.dropped[b as usize];
        let rounds = self.rounds;
        let memo = self.pair_memo(ledger, a, b);
        memo.round = rounds;
        if memo.idle == Some(versions) {
            return;
        }
        let memo = *memo;
        let (items, first_tx_arrival) = self.items_to_send(ledger, a, b, &memo, drops);
        #[cfg(test)]
        assert_eq!(
            items,
            self.items_to_send_by_scan(ledger, a, b),
            "the gossip from {a} to {b} differs from a look at the whole mempool"
        );
        let lost = !items.is_empty() && self.radio.draw_loss(a);
        let memo = self.pair_memo(ledger, a, b);
        memo.forgets = ledger.forgotten_txs(b);
        memo.drops = drops;
        // Sent transactions are in flight from now on; lost ones are not, and are looked at
        // again next round.
        memo.cursor = match (lost, first_tx_arrival) {
            (true, Some(first)) => first,
            _ => ledger.mempool_arrivals(a),
        };
        if items.is_empty() {
            memo.idle = Some(versions);
            return;
        }
        memo.idle = None;
        self.radio.queue(Message {
            from: a,
            to: b,
            items,
            lost,
        });
    }

    /// Forgets the pairs of sender `a` not looked at lately whose idle mark no longer holds
    /// (only their cursors go, which costs one look at the whole mempool when they meet
    /// again), when `a` remembers many more pairs than its `peers`.
    fn forget_pairs(&mut self, ledger: &Ledger, a: RobotId, peers: usize) {
        let memos = &mut self.pairs[a as usize];
        if memos.len() <= 2 * peers + 8 {
            return;
        }
        let recent = self.rounds.saturating_sub(PAIR_ROUNDS_KEPT);
        let version_a = ledger.node_version(a);
        memos.retain(|(b, memo)| {
            memo.round > recent || memo.idle == Some((version_a, ledger.node_version(*b)))
        });
    }

    /// What `a` has for `b`: missing blocks of a heavier chain, then unseen transactions;
    /// with the arrival number at `a` of the first transaction. Of the transactions that
    /// arrived at `a` before the pair's cursor only those `b` forgot since are looked at (all
    /// of them if the network dropped a message to `b` since, or `b`'s log of forgotten
    /// transactions no longer reaches back); see [`PairMemo::cursor`].
    fn items_to_send(
        &self,
        ledger: &Ledger,
        a: RobotId,
        b: RobotId,
        memo: &PairMemo,
        drops: u64,
    ) -> (Vec<ItemRef>, Option<u64>) {
        let mut items = self.blocks_to_send(ledger, a, b);
        let mut first_tx_arrival = None;
        let mut from = memo.cursor;
        let forgotten = ledger.forgotten_txs_since(b, memo.forgets);
        let mut again: Vec<(u64, TxHash)> = Vec::new();
        match forgotten {
            Some(txs) if memo.drops == drops => {
                for tx in txs {
                    if let Some(arrival) = ledger.mempool_arrival(a, tx) {
                        if arrival < from {
                            again.push((arrival, *tx));
                        }
                    }
                }
                again.sort_unstable();
                again.dedup();
            }
            _ => from = 0,
        }
        let unseen =
            |tx: &TxHash| !ledger.knows_tx(b, tx) && !self.radio.is_in_flight(b, &ItemRef::Tx(*tx));
        let looked_at = again
            .into_iter()
            .chain(ledger.mempool_arrived_from(a, from));
        for (arrival, tx) in looked_at {
            if unseen(&tx) {
                first_tx_arrival.get_or_insert(arrival);
                items.push(ItemRef::Tx(tx));
            }
        }
        (items, first_tx_arrival)
    }

    /// [`Network::items_to_send`] by a look at `a`'s whole mempool (tests compare them).
    #[cfg(test)]
    fn items_to_send_by_scan(&self, ledger: &Ledger, a: RobotId, b: RobotId) -> Vec<ItemRef> {
        let mut items = self.blocks_to_send(ledger, a, b);
        for tx in ledger.mempool(a) {
            if !ledger.knows_tx(b, &tx) && !self.radio.is_in_flight(b, &ItemRef::Tx(tx)) {
                items.push(ItemRef::Tx(tx));
            }
        }
        items
    }

    /// The blocks of `a`'s canonical chain that `b` lacks, ancestors first, if `b` wants them.
    fn blocks_to_send(&self, ledger: &Ledger, a: RobotId, b: RobotId) -> Vec<ItemRef> {
        let mut items = Vec::new();
        let (head_a, _) = ledger.head(a);
        let (head_b, _) = ledger.head(b);
        let (td_a, td_b) = (
            ledger.head_total_difficulty(a),
            ledger.head_total_difficulty(b),
        );
        // `b` fetches a heavier chain, or an equally heavy one when it may not seal on its own
        // head but may on `a`'s (see the liveness rule of fork choice in `Ledger`).
        let wanted = td_a > td_b
            || (td_a == td_b
                && ledger.signed_recently(&head_b, b)
                && !ledger.signed_recently(&head_a, b));
        if wanted && !ledger.knows_block(b, &head_a) {
            for hash in ledger.canonical_chain(a).iter().rev() {
                if ledger.knows_block(b, hash) {
                    break;
                }
                if self
                    .withhold
                    .as_ref()
                    .is_some_and(|w| w.hides(ledger, a, b, hash, self.radio.batch_time()))
                {
                    // Nothing at or above a hidden block can go.
                    items.clear();
                    continue;
                }
                if !self.radio.is_in_flight(b, &ItemRef::Block(*hash)) {
                    items.push(ItemRef::Block(*hash));
                }
            }
            items.reverse();
        }
        items
    }
}

/// Gossip rounds a pair's memory is kept after the pair was last looked at (10 s at the
/// paper's tick), unless its idle mark still holds.
const PAIR_ROUNDS_KEPT: u64 = 100;

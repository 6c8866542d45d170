//! The ledger's figures for `summary.json` ([`LedgerStats`]), folded from the same events as
//! the state (the `Tracker` is part of the reduced state, so replays reproduce it).
//!
//! Definitions:
//! - *canonical height*: the height of a node's head; reported as the maximum and minimum over
//!   nodes at the end.
//! - *forks seen*: over the whole block tree, the valid blocks that have an earlier valid
//!   sibling (sum over parents of children - 1): how many times the chain branched.
//! - *reorgs*: head changes, over all nodes, that removed at least one block from a node's
//!   canonical chain; *deepest reorg*: the most blocks removed at once.
//! - *propagation delay*: for each submitted transaction, the time from its submission until
//!   every node knows it (by gossip or inside a block), in simulated seconds; transactions
//!   that never reach every node are counted apart. *Inclusion delay*: from submission until
//!   the transaction first enters the canonical chain of its sender's own node.
//! - *bytes per submission*: the encoded size (rmp-serde, signature included) of each
//!   `submitModel` transaction, as a mean; the same for all transactions.
//! - *chain bytes per node*: the sum of the encoded sizes (header plus transactions) of the
//!   blocks of a node's canonical chain; mean and max over nodes, sampled every
//!   [`SAMPLE_PERIOD_MS`] of simulated time and at the end. *Stored bytes*: the same over
//!   every block a node holds, side branches included (what a node's disk would hold).
//! - *equivocations*: per sealer, the parents on which it signed two blocks that some node
//!   knows both of (`sites`), and how many nodes hold such evidence against it.
//! - *removed sealers*: the sealers that the final canonical chain removed from the signer
//!   set, by the equivocation evidence its blocks carry (`ledger/evidence.rs`).
//! - *orphaned blocks*: valid blocks not on the final canonical chain (the heaviest head over
//!   nodes, ties to the lowest node id); their transactions are *re-included* when the final
//!   chain holds them too, *dropped* otherwise.
//! - *mempool replaced / evicted*: pending transactions pushed out by the replacement rule and
//!   by the global cap, over all nodes.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::node::{Node, RejectReason};
use super::tx::{Tx, TxHash};
use super::{BlockEntry, BlockHash, Ledger};
use crate::contract::Call;
use crate::types::{RobotId, SimTime};

/// Period of the chain-size samples, in simulated milliseconds (100 s).
pub const SAMPLE_PERIOD_MS: u64 = 100_000;

/// Median and 95th percentile of a set of delays.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DelayStats {
    /// How many delays.
    pub count: u64,
    /// Median in simulated seconds (nearest rank; 0 when there are none).
    pub median_s: f64,
    /// 95th percentile in simulated seconds (nearest rank).
    pub p95_s: f64,
    /// Largest, in simulated seconds.
    pub max_s: f64,
}

impl DelayStats {
    /// The figures of `delays_ms` (in any order).
    pub fn of(mut delays_ms: Vec<u64>) -> DelayStats {
        delays_ms.sort_unstable();
        let n = delays_ms.len();
        if n == 0 {
            return DelayStats::default();
        }
        let rank =
            |q: f64| delays_ms[((q * n as f64).ceil() as usize).clamp(1, n) - 1] as f64 / 1000.0;
        DelayStats {
            count: n as u64,
            median_s: rank(0.5),
            p95_s: rank(0.95),
            max_s: delays_ms[n - 1] as f64 / 1000.0,
        }
    }
}

/// One sample of the chain size per node.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChainBytesSample {
    /// Simulated time in seconds.
    pub time_s: f64,
    /// Mean over nodes of the canonical chain's size in bytes.
    pub mean_bytes: f64,
    /// Largest canonical chain, in bytes.
    pub max_bytes: u64,
    /// Highest canonical head.
    pub max_height: u64,
    /// Mean over nodes of the bytes of every block held (side branches included).
    pub stored_mean_bytes: f64,
    /// Most bytes of blocks held by one node.
    pub stored_max_bytes: u64,
    /// Gossip bytes sent so far (lost ones included), per node: what one robot's radio has
    /// carried for the chain, on average (issue 32: the cost per node as the swarm grows).
    #[serde(default)]
    pub sent_mean_bytes: f64,
}

/// The ledger section of `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LedgerStats {
    /// Highest canonical head over nodes.
    pub canonical_height: u64,
    /// Lowest canonical head over nodes.
    pub canonical_height_min: u64,
    /// Nodes whose head is the most common head.
    pub nodes_on_common_head: u32,
    /// Valid blocks sealed (genesis excluded), on any branch.
    pub blocks_sealed: u64,
    /// Branchings of the block tree (see the module doc).
    pub forks_seen: u64,
    /// Reorganisations over all nodes.
    pub reorgs: u64,
    /// Most blocks removed by one reorganisation.
    pub deepest_reorg: u64,
    /// Transactions submitted.
    pub submissions: u64,
    /// Submission until every node knows it.
    pub propagation: DelayStats,
    /// Submitted transactions that had not reached every node at the end.
    pub not_propagated: u64,
    /// Submission until inclusion in the sender's own canonical chain.
    pub inclusion: DelayStats,
    /// Mean encoded size of a `submitModel` transaction, in bytes (0 if none).
    pub bytes_per_submission: f64,
    /// Mean encoded size of any submitted transaction, in bytes.
    pub bytes_per_tx: f64,
    /// Mean over nodes of the canonical chain's size at the end, in bytes.
    pub chain_bytes_mean: f64,
    /// Largest canonical chain at the end, in bytes.
    pub chain_bytes_max: u64,
    /// Mean over nodes of the bytes of every block held at the end (side branches included).
    pub stored_bytes_mean: f64,
    /// Most bytes of blocks held by one node at the end.
    pub stored_bytes_max: u64,
    /// Chain size over time.
    pub chain_bytes_samples: Vec<ChainBytesSample>,
    /// Gossip messages sent.
    pub messages_sent: u64,
    /// Gossip messages lost.
    pub messages_lost: u64,
    /// Gossip bytes sent (lost ones included).
    pub gossip_bytes: u64,
    /// Rejections over all nodes, by reason.
    pub rejections: BTreeMap<String, u64>,
    /// Equivocations detected, per sealer (see the module doc).
    #[serde(default)]
    pub equivocations: Vec<EquivocationStat>,
    /// Sealers removed from the signer set on the final canonical chain, ascending.
    #[serde(default)]
    pub removed_sealers: Vec<u32>,
    /// Valid blocks off the final canonical chain.
    #[serde(default)]
    pub orphaned_blocks: u64,
    /// Transactions of orphaned blocks that the final canonical chain also holds.
    #[serde(default)]
    pub orphaned_txs_reincluded: u64,
    /// Transactions of orphaned blocks that the final canonical chain does not hold.
    #[serde(default)]
    pub orphaned_txs_dropped: u64,
    /// Pending transactions replaced by the same nonce with a lower id, over all nodes.
    #[serde(default)]
    pub mempool_replaced: u64,
    /// Pending transactions evicted by the global mempool cap, over all nodes.
    #[serde(default)]
    pub mempool_evicted: u64,
    /// Largest mempool at the end, over nodes.
    #[serde(default)]
    pub mempool_max: u64,
    /// Transactions in the shared storage at the end.
    #[serde(default)]
    pub stored_txs: u64,
    /// Rounds closed by the contract's deadline on the final canonical chain.
    #[serde(default)]
    pub rounds_timed_out: u64,
    /// How fast a new model version reaches the swarm: per (version, node), the time from the
    /// version's first appearance at a node's head to its appearance at this node's head.
    /// Absent in summaries made before it, and before any version.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub version_propagation: Option<VersionPropagation>,
    /// Stake units refunded by deadlines on the final canonical chain.
    #[serde(default)]
    pub timeout_refunded_units: u64,
}

/// The propagation of model versions across the swarm (see
/// [`LedgerStats::version_propagation`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VersionPropagation {
    /// Versions seen at some node's head.
    pub versions: u64,
    /// Per (version, node that came to hold it): the delay after its first node.
    pub delay: DelayStats,
    /// (version, node) pairs never reached (the node's head stayed behind, or moved past it
    /// on another branch before the end).
    pub not_reached: u64,
}

/// Equivocation evidence against one sealer.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct EquivocationStat {
    /// The sealer.
    pub sealer: u32,
    /// Parents on which it sealed two blocks known together by some node.
    pub sites: u64,
    /// Nodes holding evidence against it.
    pub detected_by: u32,
}

#[derive(Clone, Debug)]
struct Submission {
    at: SimTime,
    size_bytes: u32,
    is_model: bool,
    /// The nodes that have seen it, one bit per robot: a node can learn a transaction twice
    /// (a full mempool evicts it and a block carries it back), and counts once.
    seen_by: Vec<u64>,
    /// How many bits of `seen_by` are set.
    seen_count: u32,
    all_seen_at: Option<SimTime>,
    included_own_at: Option<SimTime>,
}

/// The running figures (part of the ledger's reduced state).
#[derive(Clone, Debug)]
pub(crate) struct Tracker {
    robots: u32,
    submissions: BTreeMap<TxHash, Submission>,
    samples: Vec<ChainBytesSample>,
    next_sample_ms: u64,
    reorgs: u64,
    deepest_reorg: u64,
    messages: u64,
    lost: u64,
    gossip_bytes: u64,
    rejections: BTreeMap<&'static str, u64>,
    /// Per node: when its head first held each model version (`reached[node][v - 1]`, in ms),
    /// for the versions' propagation delay; not in the state digest (a figure, as the rest).
    reached: Vec<Vec<u64>>,
}

impl Tracker {
    pub(crate) fn new(robots: u32) -> Tracker {
        Tracker {
            robots,
            submissions: BTreeMap::new(),
            samples: Vec::new(),
            next_sample_ms: SAMPLE_PERIOD_MS,
            reorgs: 0,
            deepest_reorg: 0,
            messages: 0,
            lost: 0,
            gossip_bytes: 0,
            rejections: BTreeMap::new(),
            reached: vec![Vec::new(); robots as usize],
        }
    }

    /// `node`'s head moved at `at` to a block whose contract state is at model version
    /// `version`: the versions it did not hold yet reach it now.
    pub(crate) fn on_head(&mut self, node: RobotId, version: u64, at: SimTime) {
        if let Some(r) = self.reached.get_mut(node as usize) {
            while (r.len() as u64) < version {
                r.push(at.0);
            }
        }
    }

    pub(crate) fn on_submit(&mut self, hash: TxHash, tx: &Tx, size_bytes: u32, at: SimTime) {
        self.submissions.entry(hash).or_insert(Submission {
            at,
            size_bytes,
            is_model: matches!(
                tx.call,
                Call::SubmitModel { .. } | Call::SubmitUpdate { .. }
            ),
            seen_by: vec![0; self.robots.div_ceil(64) as usize],
            seen_count: 0,
            all_seen_at: None,
            included_own_at: None,
        });
    }

    /// `node` learnt the transaction (admitted it, or accepted a block carrying it while not
    /// knowing it). Only its first time counts: it may learn the transaction again after its
    /// mempool evicted it.
    pub(crate) fn on_seen(&mut self, hash: &TxHash, node: RobotId, at: SimTime) {
        if let Some(s) = self.submissions.get_mut(hash) {
            let (word, bit) = ((node / 64) as usize, 1u64 << (node % 64));
            if s.seen_by[word] & bit != 0 {
                return;
            }
            s.seen_by[word] |= bit;
            s.seen_count += 1;
            if s.seen_count == self.robots {
                s.all_seen_at = Some(at);
            }
        }
    }

    pub(crate) fn on_included_own(&mut self, hash: &TxHash, at: SimTime) {
        if let Some(s) = self.submissions.get_mut(hash) {
            s.included_own_at.get_or_insert(at);
        }
    }

    pub(crate) fn on_reorg(&mut self, depth: u64) {
        self.reorgs += 1;
        self.deepest_reorg = self.deepest_reorg.max(depth);
    }

    pub(crate) fn on_send(&mut self, bytes: u64, lost: bool) {
        self.messages += 1;
        self.lost += u64::from(lost);
        self.gossip_bytes += bytes;
    }

    pub(crate) fn on_reject(&mut self, reason: &RejectReason) {
        *self.rejections.entry(reason.kind()).or_insert(0) += 1;
    }

    /// Takes the samples due before time `at` (the state then is the state after every event
    /// earlier than the sample time).
    pub(crate) fn sample_until(
        &mut self,
        at: SimTime,
        nodes: &[Node],
        blocks: &BTreeMap<BlockHash, BlockEntry>,
    ) {
        while self.next_sample_ms <= at.0 {
            let mut sample = sample(self.next_sample_ms, nodes, blocks);
            sample.sent_mean_bytes = self.gossip_bytes as f64 / f64::from(self.robots.max(1));
            self.samples.push(sample);
            self.next_sample_ms += SAMPLE_PERIOD_MS;
        }
    }
}

fn sample(
    time_ms: u64,
    nodes: &[Node],
    blocks: &BTreeMap<BlockHash, BlockEntry>,
) -> ChainBytesSample {
    let sizes: Vec<u64> = nodes.iter().map(|n| blocks[&n.head].chain_bytes).collect();
    ChainBytesSample {
        time_s: time_ms as f64 / 1000.0,
        mean_bytes: sizes.iter().sum::<u64>() as f64 / sizes.len().max(1) as f64,
        max_bytes: sizes.iter().copied().max().unwrap_or(0),
        max_height: nodes
            .iter()
            .map(|n| n.canonical.len() as u64 - 1)
            .max()
            .unwrap_or(0),
        stored_mean_bytes: nodes.iter().map(|n| n.stored_bytes).sum::<u64>() as f64
            / nodes.len().max(1) as f64,
        stored_max_bytes: nodes.iter().map(|n| n.stored_bytes).max().unwrap_or(0),
        sent_mean_bytes: 0.0,
    }
}

/// The figures of a ledger now.
pub(crate) fn stats(ledger: &Ledger) -> LedgerStats {
    let t = &ledger.metrics;
    let heights: Vec<u64> = ledger
        .nodes
        .iter()
        .map(|n| n.canonical.len() as u64 - 1)
        .collect();
    let mut head_counts: BTreeMap<BlockHash, u32> = BTreeMap::new();
    for n in &ledger.nodes {
        *head_counts.entry(n.head).or_insert(0) += 1;
    }
    let mut last = sample(ledger.now.0, &ledger.nodes, &ledger.blocks);
    last.sent_mean_bytes = t.gossip_bytes as f64 / f64::from(t.robots.max(1));
    let subs: Vec<&Submission> = t.submissions.values().collect();
    let mut samples = t.samples.clone();
    if samples.last().map(|s| s.time_s) != Some(last.time_s) {
        samples.push(last.clone());
    }
    let final_node = final_node(ledger);
    let orphans = Orphans::of(ledger, final_node);
    let final_state = ledger
        .nodes
        .get(final_node)
        .map(|n| &ledger.blocks[&n.head].state);
    let removed_sealers = ledger
        .nodes
        .get(final_node)
        .map_or_else(Vec::new, |n| ledger.removed_signers(&n.head));
    LedgerStats {
        equivocations: equivocations(ledger),
        removed_sealers,
        orphaned_blocks: orphans.blocks,
        orphaned_txs_reincluded: orphans.reincluded,
        orphaned_txs_dropped: orphans.dropped,
        mempool_replaced: ledger.nodes.iter().map(|n| n.mempool_replaced).sum(),
        mempool_evicted: ledger.nodes.iter().map(|n| n.mempool_evicted).sum(),
        mempool_max: ledger
            .nodes
            .iter()
            .map(|n| n.mempool.len() as u64)
            .max()
            .unwrap_or(0),
        stored_txs: ledger.txs.len() as u64,
        rounds_timed_out: final_state.map_or(0, |s| s.rounds_timed_out),
        timeout_refunded_units: final_state.map_or(0, |s| s.timeout_refunded_units),
        canonical_height: heights.iter().copied().max().unwrap_or(0),
        canonical_height_min: heights.iter().copied().min().unwrap_or(0),
        nodes_on_common_head: head_counts.values().copied().max().unwrap_or(0),
        blocks_sealed: ledger.blocks.len() as u64 - 1,
        forks_seen: ledger
            .blocks
            .values()
            .map(|e| u64::from(e.children.saturating_sub(1)))
            .sum(),
        reorgs: t.reorgs,
        deepest_reorg: t.deepest_reorg,
        submissions: subs.len() as u64,
        propagation: DelayStats::of(delays_ms(&subs, |s| s.all_seen_at)),
        not_propagated: subs.iter().filter(|s| s.all_seen_at.is_none()).count() as u64,
        inclusion: DelayStats::of(delays_ms(&subs, |s| s.included_own_at)),
        bytes_per_submission: mean_size(subs.iter().filter(|s| s.is_model)),
        bytes_per_tx: mean_size(subs.iter()),
        chain_bytes_mean: last.mean_bytes,
        chain_bytes_max: last.max_bytes,
        stored_bytes_mean: last.stored_mean_bytes,
        stored_bytes_max: last.stored_max_bytes,
        chain_bytes_samples: samples,
        version_propagation: version_propagation(&t.reached),
        messages_sent: t.messages,
        messages_lost: t.lost,
        gossip_bytes: t.gossip_bytes,
        rejections: t
            .rejections
            .iter()
            .map(|(k, v)| ((*k).to_string(), *v))
            .collect(),
    }
}

/// The propagation delay of the model versions: for each version and each node whose head
/// came to hold it, the time from the first node's holding it (its creation, at the node that
/// sealed or first received the block making it) to this node's; `None` before any version.
fn version_propagation(reached: &[Vec<u64>]) -> Option<VersionPropagation> {
    let versions = reached.iter().map(Vec::len).max().unwrap_or(0);
    if versions == 0 {
        return None;
    }
    let mut delays = Vec::new();
    let mut missing = 0;
    for v in 0..versions {
        let first = reached.iter().filter_map(|r| r.get(v)).min().copied();
        let Some(first) = first else { continue };
        for r in reached {
            match r.get(v) {
                Some(&t) => delays.push(t - first),
                None => missing += 1,
            }
        }
    }
    Some(VersionPropagation {
        versions: versions as u64,
        delay: DelayStats::of(delays),
        not_reached: missing,
    })
}

/// The node whose head ends the final canonical chain: the heaviest head, ties to the lowest
/// node id (0 without nodes).
fn final_node(ledger: &Ledger) -> usize {
    (0..ledger.nodes.len())
        .max_by_key(|&i| {
            (
                ledger.blocks[&ledger.nodes[i].head].total_difficulty,
                std::cmp::Reverse(i),
            )
        })
        .unwrap_or(0)
}

/// The valid blocks off the final canonical chain and the fate of their transactions.
struct Orphans {
    /// Blocks not on the final canonical chain.
    blocks: u64,
    /// Their distinct transactions that the final chain holds too.
    reincluded: u64,
    /// Their distinct transactions that it does not.
    dropped: u64,
}

impl Orphans {
    /// The orphans of `ledger` against the canonical chain of node `final_node`.
    fn of(ledger: &Ledger, final_node: usize) -> Orphans {
        let canonical: std::collections::BTreeSet<BlockHash> = ledger
            .nodes
            .get(final_node)
            .map(|n| n.canonical.iter().copied().collect())
            .unwrap_or_default();
        let final_txs: std::collections::BTreeSet<TxHash> = canonical
            .iter()
            .flat_map(|h| ledger.blocks[h].block.txs.iter().copied())
            .collect();
        let mut blocks = 0;
        let mut orphan_txs = std::collections::BTreeSet::new();
        for (hash, entry) in &ledger.blocks {
            if !canonical.contains(hash) {
                blocks += 1;
                orphan_txs.extend(entry.block.txs.iter().copied());
            }
        }
        let reincluded = orphan_txs.iter().filter(|t| final_txs.contains(t)).count() as u64;
        Orphans {
            blocks,
            reincluded,
            dropped: orphan_txs.len() as u64 - reincluded,
        }
    }
}

/// Per sealer that some node holds evidence against: the parents on which it signed twice,
/// and how many nodes hold such evidence; in sealer order.
fn equivocations(ledger: &Ledger) -> Vec<EquivocationStat> {
    let mut by_sealer: BTreeMap<u32, (std::collections::BTreeSet<BlockHash>, u32)> =
        BTreeMap::new();
    for n in &ledger.nodes {
        let mut against = std::collections::BTreeSet::new();
        for (signer, parent) in n.evidence.keys() {
            by_sealer.entry(*signer).or_default().0.insert(*parent);
            against.insert(*signer);
        }
        for signer in against {
            by_sealer.entry(signer).or_default().1 += 1;
        }
    }
    by_sealer
        .into_iter()
        .map(|(sealer, (sites, detected_by))| EquivocationStat {
            sealer,
            sites: sites.len() as u64,
            detected_by,
        })
        .collect()
}

/// The delays from each submission until the moment `reached` gives it, in simulated ms, of
/// the submissions that reached it.
fn delays_ms(subs: &[&Submission], reached: fn(&Submission) -> Option<SimTime>) -> Vec<u64> {
    subs.iter()
        .filter_map(|s| reached(s).map(|a| a.0 - s.at.0))
        .collect()
}

/// The mean encoded size of `subs`, in bytes (0 without any).
fn mean_size<'a>(subs: impl Iterator<Item = &'a &'a Submission>) -> f64 {
    let v: Vec<u32> = subs.map(|s| s.size_bytes).collect();
    if v.is_empty() {
        0.0
    } else {
        v.iter().map(|&b| f64::from(b)).sum::<f64>() / v.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(delays: &[u64], expect: (u64, f64, f64)) {
        let s = DelayStats::of(delays.to_vec());
        assert_eq!((s.count, s.median_s, s.p95_s), expect, "{delays:?}");
    }

    #[test]
    fn delay_percentiles_use_the_nearest_rank() {
        check(&[], (0, 0.0, 0.0));
        check(&[1500], (1, 1.5, 1.5));
        check(&[3000, 1000, 2000], (3, 2.0, 3.0));
        check(
            &(1..=100).map(|i| i * 1000).collect::<Vec<_>>(),
            (100, 50.0, 95.0),
        );
    }

    #[test]
    fn a_transaction_learnt_again_after_an_eviction_counts_its_node_once() {
        // 960 robots at the paper's density filled mempools (MEMPOOL_MAX): a node evicted a
        // transaction, a block carried it back, and the node was counted twice (a panic, and
        // before it an early "seen by all").
        let keys = crate::ledger::keys::Keys::new(1, 70);
        let tx = Tx::signed(
            &keys,
            3,
            0,
            0,
            Call::Transfer {
                to: 1,
                amount_units: 1,
            },
        );
        let (hash, size) = tx.hash_and_size();
        let mut t = Tracker::new(70);
        t.on_submit(hash, &tx, size, SimTime(0));
        for node in 0..69 {
            t.on_seen(&hash, node, SimTime(10));
        }
        t.on_seen(&hash, 65, SimTime(20));
        assert_eq!(t.submissions[&hash].all_seen_at, None);
        t.on_seen(&hash, 69, SimTime(30));
        assert_eq!(t.submissions[&hash].all_seen_at, Some(SimTime(30)));
        t.on_seen(&hash, 0, SimTime(40));
        assert_eq!(t.submissions[&hash].seen_count, 70);
    }
}

#[cfg(test)]
mod version_tests {
    use super::*;

    #[test]
    fn a_versions_delay_runs_from_its_first_node_and_missing_nodes_count_apart() {
        let mut t = Tracker::new(3);
        t.on_head(0, 1, SimTime(10_000));
        t.on_head(1, 2, SimTime(14_000)); // versions 1 and 2 at once
        t.on_head(0, 2, SimTime(12_000));
        t.on_head(0, 1, SimTime(20_000)); // a reorg back changes nothing
        let p = version_propagation(&t.reached).unwrap();
        // Version 1: 0 s (node 0), 4 s (node 1), node 2 never; version 2: 0 s, 2 s, never.
        assert_eq!((p.versions, p.delay.count, p.not_reached), (2, 4, 2));
        assert_eq!((p.delay.median_s, p.delay.max_s), (0.0, 4.0));
        assert!(version_propagation(&Tracker::new(3).reached).is_none());
    }
}

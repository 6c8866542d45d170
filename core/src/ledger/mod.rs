//! One Clique-style proof-of-authority node per robot, gossiping over the radio graph
//! (docs/SPEC.md section 3).
//!
//! [`Ledger`] is the reduced state of every node of the swarm, folded from [`LedgerEvent`]s by
//! [`Ledger::apply`], a pure reducer: the same events give the same state, bit for bit.
//! [`network::Network`] is the driver side: it decides, from the ledger's state, the peer sets
//! and its own seeded randomness, which event comes next (sealings, gossip sends, deliveries).
//!
//! Fork choice: the greatest total difficulty; a tie keeps the current head, except that a
//! node which may not seal on its head (Clique's recent-signer rule) moves to an equally heavy
//! known block on which it may: without that exception equally heavy branches can deadlock
//! (see `Ledger::unstick`).
//!
//! Storage is shared: a block or transaction is stored once, by id, whatever the number of
//! nodes that know it; each node holds only ids of blocks, and which transactions it holds
//! is one bit per node in the transaction's entry. The contract state after a block is a pure
//! function of the block's chain, so it is computed once, when the block is first validated,
//! and kept with the block: a reorganisation costs no re-execution at all (the states of the
//! new branch were computed when its blocks arrived), and every node reads the same state.
//! Validation results (signatures, header rules, execution) are cached by id for the same
//! reason. This is an optimisation only: a node's outcome for an item is the same as if it
//! verified the item itself, since those results depend on the item and its ancestors alone;
//! the node-dependent checks (parent known by the node, nonce against the node's chain, block
//! from the future) are never cached.

pub mod block;
pub mod keys;
pub mod metrics;
pub mod network;
pub mod node;
pub mod synthetic;
pub mod tx;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

pub use block::{Block, BlockHash, BlockHeader, WireBlock, WireItem};
pub use keys::{Keys, Sig};
pub use metrics::{EquivocationStat, LedgerStats};
pub use network::Network;
pub use node::{Node, RejectReason, Rejection};
pub use tx::{Tx, TxHash};

use crate::config::Config;
use crate::contract::{Call, ContractParams, ContractState, Outcome};
use crate::types::{Digest, RobotId, SimTime};

/// A pending transaction may be at most this many nonces ahead of the sender's next expected
/// nonce; further ahead it is refused as out of order ([`RejectReason::NonceGap`]). Bounds the
/// mempool against a flood of future transactions.
pub const MAX_NONCE_GAP: u64 = 64;

/// Largest encoded block (header plus transactions) a node accepts or seals, in bytes: the
/// role of Clique's gas limit. A `paper` submission encodes to about 14 KB, so a block holds
/// some 35 of them, more than twice a round of 15.
pub const MAX_BLOCK_BYTES: u64 = 512 * 1024;

/// Largest foreign item ([`LedgerEvent::Inject`]) a node reads, in bytes; longer input is
/// refused before it is decoded.
pub const MAX_WIRE_BYTES: usize = MAX_BLOCK_BYTES as usize + 4096;

/// Most pending transactions a node keeps per sender.
pub const MEMPOOL_PER_SENDER: u32 = 16;

/// Most pending transactions a node keeps in all. A full mempool admits a transaction only by
/// evicting the highest nonce of the sender with the most pending, and only if that sender
/// has more pending than the newcomer's sender (so a flooder cannot crowd out the others).
pub const MEMPOOL_MAX: u32 = 256;

/// Invalid block ids whose reason is cached (first in, first out).
pub const MAX_INVALID_CACHE: usize = 4096;

/// Rejections kept per node (the latest; the total is counted).
pub const MAX_REJECTIONS_KEPT: usize = 256;

/// Refused transaction ids remembered per node (first in, first out).
pub const MAX_REFUSED_KEPT: usize = 1024;

/// Equivocation evidence entries kept per node.
pub const MAX_EVIDENCE: usize = 256;

/// A block or a transaction, by id.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum ItemRef {
    /// A block.
    Block(BlockHash),
    /// A transaction.
    Tx(TxHash),
}

/// One step of the ledger. Content is logged once: a submitted transaction carries its body;
/// a sealing names its parent and transactions (the reducer rebuilds and signs the exact
/// block); gossip names items by id. Times come with the event (see [`Ledger::apply`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum LedgerEvent {
    /// A robot submits a transaction: it enters the sender's own node.
    Submit {
        /// The signed transaction.
        tx: Tx,
    },
    /// `node` seals a block on its head `parent` holding `txs` in this order, at the event's
    /// time. Difficulty, height and signature follow from the rules and the node's key.
    Seal {
        /// The sealing node.
        node: RobotId,
        /// Its head (checked).
        parent: BlockHash,
        /// Transaction ids, in execution order; the node must know them.
        txs: Vec<TxHash>,
    },
    /// `from` sends `items` to `to` in one message; a `lost` message never arrives. Messages
    /// are numbered by the order of their `Send` events, from 0.
    Send {
        /// Sender.
        from: RobotId,
        /// Receiver.
        to: RobotId,
        /// Blocks (ancestors first) then transactions.
        items: Vec<ItemRef>,
        /// The radio lost it.
        lost: bool,
    },
    /// Message number `message` arrives at its receiver.
    Deliver {
        /// The message's number.
        message: u64,
    },
    /// Foreign bytes (a [`WireItem`] encoding, possibly forged or garbage) arrive at `node`
    /// from outside the honest gossip: Byzantine input and fault injection.
    Inject {
        /// The receiving node.
        node: RobotId,
        /// The encoded item.
        bytes: Vec<u8>,
    },
    /// `node` restarts after a crash (fault injection): its mempool and every message in
    /// flight to it are lost; its chain (on disk) stays, and it resyncs by gossip.
    Restart {
        /// The node.
        node: RobotId,
    },
}

impl LedgerEvent {
    /// The position of the event's kind in the order of simultaneous events.
    pub fn kind_rank(&self) -> u8 {
        match self {
            LedgerEvent::Deliver { .. } => 0,
            LedgerEvent::Inject { .. } => 1,
            LedgerEvent::Submit { .. } => 2,
            LedgerEvent::Seal { .. } => 3,
            LedgerEvent::Send { .. } => 4,
            LedgerEvent::Restart { .. } => 1,
        }
    }
}

/// An event the reducer cannot apply: the log is inconsistent (never a rejected item, which
/// is a recorded [`Rejection`]). The state is unchanged when this is returned.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LedgerError {
    /// A node id out of range.
    #[error("unknown node {node}: the swarm has nodes 0..{robots}")]
    UnknownNode {
        /// The id.
        node: RobotId,
        /// Number of nodes.
        robots: u32,
    },
    /// Events must come in time order.
    #[error(
        "event at {at} comes after an event at {now}: ledger events must be applied in time order"
    )]
    TimeWentBack {
        /// The event's time.
        at: SimTime,
        /// The last applied time.
        now: SimTime,
    },
    /// A sealing not on the sealer's head.
    #[error("node {node} seals on {parent:?} but its head is {head:?}")]
    SealNotOnHead {
        /// The node.
        node: RobotId,
        /// The parent named by the event.
        parent: BlockHash,
        /// The node's head.
        head: BlockHash,
    },
    /// A sealing that breaks the rules (the network never emits one).
    #[error("node {node} may not seal this block: {reason}")]
    InvalidSeal {
        /// The node.
        node: RobotId,
        /// Why.
        reason: RejectReason,
    },
    /// An item the acting node does not know (a sealed transaction, a sent item).
    #[error("node {node} does not know {item:?}")]
    UnknownItem {
        /// The node.
        node: RobotId,
        /// The item.
        item: ItemRef,
    },
    /// A delivery of a message that was never sent, was lost, or was already delivered.
    #[error("message {message} is not in flight")]
    UnknownMessage {
        /// The number.
        message: u64,
    },
    /// A message from a node to itself, or without items.
    #[error("bad message from {from} to {to}: {why}")]
    BadMessage {
        /// Sender.
        from: RobotId,
        /// Receiver.
        to: RobotId,
        /// What is wrong.
        why: String,
    },
}

/// What applying an event did (for the driver and for tests).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Applied {
    /// Items accepted by the acting or receiving node.
    pub accepted: u32,
    /// Items refused (each recorded at the node).
    pub rejected: u32,
    /// Items the node already knew.
    pub duplicates: u32,
    /// Nodes whose head changed.
    pub head_changes: u32,
}

/// A valid block in the shared storage, with everything derived from its chain.
#[derive(Clone, Debug)]
pub struct BlockEntry {
    /// The block.
    pub block: Arc<Block>,
    /// Its encoded size: header plus transactions, in bytes.
    pub size_bytes: u64,
    /// Sum of the difficulties from genesis.
    pub total_difficulty: u64,
    /// Sum of the sizes of the blocks from genesis to this one.
    pub chain_bytes: u64,
    /// The contract state after the block.
    pub state: ContractState,
    /// `state.digest()`, computed once (checkpoints read it for every node's head).
    pub state_digest: Digest,
    /// Clique's recent signers of a child: bit `s` is set when robot `s` sealed one of the
    /// last floor(N/2) blocks of the chain ending with this one (genesis excluded). One bit
    /// per robot, computed once, so that [`Ledger::signed_recently`] costs one lookup instead
    /// of a walk of up to N/2 ancestors.
    pub recent_signers: Arc<[u64]>,
    /// Each sender's next nonce after the block.
    pub next_nonce: Arc<[u64]>,
    /// The outcome of each transaction, in block order.
    pub receipts: Arc<[Outcome]>,
    /// Valid children seen so far (for the fork count).
    pub children: u32,
}

/// A transaction in the shared storage.
#[derive(Clone, Debug)]
pub struct TxEntry {
    /// The transaction.
    pub tx: Arc<Tx>,
    /// Its encoded size in bytes.
    pub size_bytes: u32,
    /// The checks that depend only on the transaction (sender id, size, signature), done once.
    pub intrinsic: Result<(), RejectReason>,
    /// The nodes that hold the transaction (pending in their mempool, or carried by a block
    /// they know), one bit per robot: every node's set of known transactions, kept once per
    /// transaction rather than once per node (N bits instead of N ids).
    held_by: Box<[u64]>,
}

impl TxEntry {
    /// Whether `node` holds the transaction (pending, or in a block it knows).
    pub fn held_by(&self, node: RobotId) -> bool {
        self.held_by
            .get((node / 64) as usize)
            .is_some_and(|word| word & (1u64 << (node % 64)) != 0)
    }

    /// Marks whether `node` holds the transaction; returns whether that changed.
    fn set_held_by(&mut self, node: RobotId, held: bool) -> bool {
        let bit = 1u64 << (node % 64);
        let word = &mut self.held_by[(node / 64) as usize];
        let was = *word & bit != 0;
        if held {
            *word |= bit;
        } else {
            *word &= !bit;
        }
        was != held
    }
}

/// A message in flight.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Flight {
    from: RobotId,
    to: RobotId,
    items: Vec<ItemRef>,
}

/// The nodes whose head or head time changed, in order, for the driver's sealing schedule
/// ([`Network`] reads it instead of looking at every node at every step). Bounded: a reader
/// that fell behind what it keeps looks at every node. Not part of the reduced state's
/// digest: it records when the state changed, not what it is.
#[derive(Clone, Debug, Default)]
struct HeadJournal {
    /// The position of `nodes[0]`.
    start: u64,
    nodes: std::collections::VecDeque<RobotId>,
}

impl HeadJournal {
    fn push(&mut self, node: RobotId) {
        self.nodes.push_back(node);
        if self.nodes.len() > HEAD_JOURNAL_KEPT {
            self.nodes.pop_front();
            self.start += 1;
        }
    }

    fn end(&self) -> u64 {
        self.start + self.nodes.len() as u64
    }

    fn since(&self, since: u64) -> Option<impl Iterator<Item = RobotId> + '_> {
        let skip = since.checked_sub(self.start)?;
        (since <= self.end()).then(|| self.nodes.iter().skip(skip as usize).copied())
    }
}

/// Head changes the ledger's journal keeps (see `HeadJournal`).
const HEAD_JOURNAL_KEPT: usize = 1 << 16;

/// The contract parameters for blocks sealed after a time.
#[derive(Clone, Debug)]
struct Epoch {
    after_ms: u64,
    params: ContractParams,
}

/// The reduced state of every node of the swarm, with shared storage.
#[derive(Clone, Debug)]
pub struct Ledger {
    /// The contract's rules, oldest first: the genesis parameters from time 0, then one entry
    /// per reconfiguration, for the blocks whose timestamp is after its `after_ms`.
    epochs: Vec<Epoch>,
    keys: Keys,
    robots: u32,
    period_ms: u64,
    genesis: BlockHash,
    blocks: BTreeMap<BlockHash, BlockEntry>,
    /// Valid blocks by (parent, signer): two entries are an equivocation.
    sealed_on: BTreeMap<(BlockHash, RobotId), Vec<BlockHash>>,
    invalid_blocks: BTreeMap<BlockHash, RejectReason>,
    invalid_order: std::collections::VecDeque<BlockHash>,
    /// Each node's clock minus the true time, ms (faults).
    skews_ms: Vec<i64>,
    txs: BTreeMap<TxHash, TxEntry>,
    nodes: Vec<Node>,
    flights: BTreeMap<u64, Flight>,
    messages_sent: u64,
    now: SimTime,
    metrics: metrics::Tracker,
    head_journal: HeadJournal,
}

impl Ledger {
    /// Every node at genesis. Keys derive from `seed`; the genesis block commits to `params`.
    pub fn new(config: &Config, seed: u64, params: ContractParams) -> Ledger {
        let robots = config.world.robots;
        assert_eq!(
            params.robots, robots,
            "contract parameters and config disagree on robots"
        );
        let period_ms = (config.ledger.block_period_s * 1000.0).round() as u64;
        let header = BlockHeader {
            parent: Digest::of(&rmp_serde::to_vec(&params).expect("parameters encode")),
            height: 0,
            timestamp_ms: 0,
            signer: block::GENESIS_SIGNER,
            difficulty: 0,
            tx_root: block::tx_root(&[]),
            signature: Sig::ZERO,
        };
        let (genesis, size) = header.hash_and_size();
        let state = ContractState::genesis(&params);
        let entry = BlockEntry {
            block: Arc::new(Block {
                header,
                txs: Vec::new(),
            }),
            size_bytes: u64::from(size),
            total_difficulty: 0,
            chain_bytes: u64::from(size),
            state_digest: state.digest(),
            state,
            recent_signers: vec![0u64; robots.div_ceil(64) as usize].into(),
            next_nonce: vec![0u64; robots as usize].into(),
            receipts: Arc::from(Vec::new()),
            children: 0,
        };
        Ledger {
            keys: Keys::new(seed, robots).for_chain(genesis),
            sealed_on: BTreeMap::new(),
            invalid_order: std::collections::VecDeque::new(),
            skews_ms: config.faults.skews_ms(robots),
            robots,
            period_ms,
            genesis,
            blocks: BTreeMap::from([(genesis, entry)]),
            invalid_blocks: BTreeMap::new(),
            txs: BTreeMap::new(),
            nodes: (0..robots).map(|_| Node::new(genesis)).collect(),
            flights: BTreeMap::new(),
            messages_sent: 0,
            now: SimTime(0),
            metrics: metrics::Tracker::new(robots),
            head_journal: HeadJournal::default(),
            epochs: vec![Epoch {
                after_ms: 0,
                params,
            }],
        }
    }

    // ----- queries -------------------------------------------------------------------------

    /// Number of nodes.
    pub fn robots(&self) -> u32 {
        self.robots
    }

    /// The contract parameters at genesis (supply and genesis model never change).
    pub fn params(&self) -> &ContractParams {
        &self.epochs[0].params
    }

    /// The index of the contract rules that a block with timestamp `timestamp_ms` runs under.
    fn epoch_at(&self, timestamp_ms: u64) -> usize {
        self.epochs
            .iter()
            .rposition(|e| e.after_ms < timestamp_ms)
            .unwrap_or(0)
    }

    /// The contract parameters a block with timestamp `timestamp_ms` runs under.
    pub fn params_at(&self, timestamp_ms: u64) -> &ContractParams {
        &self.epochs[self.epoch_at(timestamp_ms)].params
    }

    /// The contract parameters of the blocks sealed from now on.
    pub fn current_params(&self) -> &ContractParams {
        &self.epochs.last().expect("the genesis epoch").params
    }

    /// Changes the contract's rules for every block whose timestamp is after `after_ms` (a
    /// reconfiguration). Blocks already stored have timestamps up to the ledger's time, so the
    /// change never re-executes one. Supply, accounts and the genesis model must not change.
    pub fn reconfigure(&mut self, after_ms: u64, params: ContractParams) -> Result<(), String> {
        if after_ms < self.now.0 {
            return Err(format!(
                "a reconfiguration after {after_ms} ms comes when the ledger is at {}",
                self.now
            ));
        }
        let last = self.epochs.last().expect("the genesis epoch");
        if after_ms < last.after_ms {
            return Err(format!(
                "a reconfiguration after {after_ms} ms precedes the one after {} ms",
                last.after_ms
            ));
        }
        let genesis = &self.epochs[0].params;
        if params.robots != genesis.robots
            || params.initial_units != genesis.initial_units
            || params.genesis_weights != genesis.genesis_weights
        {
            return Err(
                "a reconfiguration cannot change the accounts, the supply or the genesis model"
                    .to_string(),
            );
        }
        params
            .check()
            .map_err(|e| format!("invalid contract parameters: {e}"))?;
        self.epochs.push(Epoch { after_ms, params });
        Ok(())
    }

    /// The contract state after the parent's, entering a block with timestamp `timestamp_ms`
    /// whose parent has `parent_ms`: when the block is the chain's first under new rules, the
    /// open round is restarted (its stakes refunded). Returns the rules to execute it with.
    fn enter_block(&self, state: &mut ContractState, parent_ms: u64, timestamp_ms: u64) -> usize {
        let epoch = self.epoch_at(timestamp_ms);
        if epoch != self.epoch_at(parent_ms) {
            state.restart_round();
        }
        state.enter_block(&self.epochs[epoch].params, timestamp_ms);
        epoch
    }

    /// A node's clock at true time `at` (its skew applied), in ms.
    pub fn clock_ms(&self, node: RobotId, at: SimTime) -> u64 {
        let skew = self.skews_ms.get(node as usize).copied().unwrap_or(0);
        at.0.saturating_add_signed(skew)
    }

    /// The keys of the swarm (the driver signs with them in [`Ledger::make_tx`]).
    pub fn keys(&self) -> &Keys {
        &self.keys
    }

    /// The genesis block's id.
    pub fn genesis(&self) -> BlockHash {
        self.genesis
    }

    /// The block period in milliseconds.
    pub fn period_ms(&self) -> u64 {
        self.period_ms
    }

    /// Time of the last applied event.
    pub fn now(&self) -> SimTime {
        self.now
    }

    /// A node (panics on an id out of range: ids come from the driver, not from input).
    pub fn node(&self, node: RobotId) -> &Node {
        &self.nodes[node as usize]
    }

    /// The node's head: id and height.
    pub fn head(&self, node: RobotId) -> (BlockHash, u64) {
        let n = self.node(node);
        (n.head, n.canonical.len() as u64 - 1)
    }

    /// When the node's head last changed.
    pub fn head_since(&self, node: RobotId) -> SimTime {
        self.node(node).head_since
    }

    /// The contract state at the node's head.
    pub fn head_state(&self, node: RobotId) -> &ContractState {
        &self.blocks[&self.node(node).head].state
    }

    /// The digest of the contract state at the node's head (computed once per block).
    pub fn head_state_digest(&self, node: RobotId) -> Digest {
        self.blocks[&self.node(node).head].state_digest
    }

    /// The node's canonical chain, genesis first.
    pub fn canonical_chain(&self, node: RobotId) -> &[BlockHash] {
        &self.node(node).canonical
    }

    /// A valid block by id.
    pub fn block(&self, hash: &BlockHash) -> Option<&BlockEntry> {
        self.blocks.get(hash)
    }

    /// Every valid block, by id.
    pub fn blocks(&self) -> impl Iterator<Item = (&BlockHash, &BlockEntry)> {
        self.blocks.iter()
    }

    /// A stored transaction by id.
    pub fn tx(&self, hash: &TxHash) -> Option<&TxEntry> {
        self.txs.get(hash)
    }

    /// The contract state after a valid block (e.g. `canonical_chain(node)[height]`).
    pub fn state_after(&self, hash: &BlockHash) -> Option<&ContractState> {
        self.blocks.get(hash).map(|e| &e.state)
    }

    /// The receipts (one outcome per transaction) of a valid block.
    pub fn receipts(&self, hash: &BlockHash) -> Option<&[Outcome]> {
        self.blocks.get(hash).map(|e| &e.receipts[..])
    }

    /// Whether the node has the block in its tree.
    pub fn knows_block(&self, node: RobotId, hash: &BlockHash) -> bool {
        self.node(node).known_blocks.contains(hash)
    }

    /// Whether the node has the transaction (pending or in a known block) or refused it
    /// recently (the bounded refused set): either way a peer need not send it.
    pub fn knows_tx(&self, node: RobotId, hash: &TxHash) -> bool {
        self.holds_tx(node, hash) || self.node(node).refused_txs.contains(hash)
    }

    /// Whether the node holds the transaction: pending, or carried by a block it knows (then
    /// it is stored).
    pub fn holds_tx(&self, node: RobotId, hash: &TxHash) -> bool {
        self.txs.get(hash).is_some_and(|e| e.held_by(node))
    }

    /// How many transactions the node holds (pending or in a known block).
    pub fn known_tx_count(&self, node: RobotId) -> usize {
        self.node(node).held_txs as usize
    }

    /// Marks that `node` holds the stored transaction `hash`; returns whether it is new to it.
    fn hold_tx(&mut self, node: RobotId, hash: &TxHash) -> bool {
        let entry = self
            .txs
            .get_mut(hash)
            .expect("a held transaction is stored");
        let fresh = entry.set_held_by(node, true);
        if fresh {
            self.nodes[node as usize].held_txs += 1;
        }
        fresh
    }

    /// Marks that `node` no longer holds the stored transaction `hash`.
    fn release_tx(&mut self, node: RobotId, hash: &TxHash) {
        let entry = self
            .txs
            .get_mut(hash)
            .expect("a held transaction is stored");
        if entry.set_held_by(node, false) {
            self.nodes[node as usize].held_txs -= 1;
        }
    }

    /// Remembers a refused, replaced or evicted transaction in the node's bounded refused set
    /// (first in, first out), so that it is not examined again while it is there. What the
    /// bound pushes out and the node does not hold is logged as forgotten.
    fn remember_refused(&mut self, node: RobotId, hash: TxHash) {
        let n = &mut self.nodes[node as usize];
        if n.refused_txs.insert(hash) {
            n.refused_order.push_back(hash);
            if n.refused_order.len() > MAX_REFUSED_KEPT {
                let old = n.refused_order.pop_front().expect("not empty");
                n.refused_txs.remove(&old);
                let held = self.txs.get(&old).is_some_and(|e| e.held_by(node));
                if !held {
                    self.nodes[node as usize].forgotten.push(old);
                }
            }
        }
    }

    /// The node's pending transactions, in arrival order.
    pub fn mempool(&self, node: RobotId) -> Vec<TxHash> {
        self.mempool_arrived_from(node, 0).map(|(_, h)| h).collect()
    }

    /// The node's pending transactions that arrived at it at or after arrival number `from`,
    /// as (arrival number, id) in arrival order. Arrival numbers only grow: a transaction
    /// that enters the mempool again gets a new one.
    pub fn mempool_arrived_from(
        &self,
        node: RobotId,
        from: u64,
    ) -> impl Iterator<Item = (u64, TxHash)> + '_ {
        self.node(node).mempool.arrived_from(from)
    }

    /// The node's next arrival number (every pending transaction's is lower).
    pub fn mempool_arrivals(&self, node: RobotId) -> u64 {
        self.node(node).arrivals
    }

    /// How many transactions the node forgot (see [`Ledger::knows_tx`]: a transaction it
    /// knew or had refused, and no longer does); while this count stays, a transaction it
    /// knows stays known.
    pub fn forgotten_txs(&self, node: RobotId) -> u64 {
        self.node(node).forgotten.end()
    }

    /// The transactions the node forgot from number `since` on (numbered from 0 in order),
    /// or None when its bounded log (the latest [`node::FORGET_LOG_KEPT`]) no longer reaches
    /// back to it.
    pub fn forgotten_txs_since(
        &self,
        node: RobotId,
        since: u64,
    ) -> Option<impl Iterator<Item = &TxHash> + '_> {
        self.node(node).forgotten.since(since)
    }

    /// The arrival number at `node` of a pending transaction.
    pub fn mempool_arrival(&self, node: RobotId, hash: &TxHash) -> Option<u64> {
        self.node(node).mempool.arrival(hash)
    }

    /// The total difficulty of the node's head.
    pub fn head_total_difficulty(&self, node: RobotId) -> u64 {
        self.node(node).head_td
    }

    /// Where the journal of head changes ends now (see [`Ledger::head_changes_since`]).
    pub fn head_journal_end(&self) -> u64 {
        self.head_journal.end()
    }

    /// The nodes whose head or head time changed after position `since` of the journal of
    /// head changes, oldest first (a node may appear more than once); None when the bounded
    /// journal no longer holds that position (the caller must then look at every node).
    pub fn head_changes_since(&self, since: u64) -> Option<impl Iterator<Item = RobotId> + '_> {
        self.head_journal.since(since)
    }

    /// The change counter of the node's knowledge.
    pub fn node_version(&self, node: RobotId) -> u64 {
        self.node(node).version
    }

    /// Messages sent so far (the next message's number).
    pub fn messages_sent(&self) -> u64 {
        self.messages_sent
    }

    /// The messages in flight, in number order: (number, sender, receiver, items).
    pub fn messages_in_flight(&self) -> Vec<(u64, RobotId, RobotId, &[ItemRef])> {
        self.flights
            .iter()
            .map(|(seq, f)| (*seq, f.from, f.to, &f.items[..]))
            .collect()
    }

    /// Encoded bytes of an item as it travels (a block with all its transactions).
    pub fn item_bytes(&self, item: &ItemRef) -> u64 {
        match item {
            ItemRef::Block(h) => self.blocks.get(h).map_or(0, |e| e.size_bytes),
            ItemRef::Tx(h) => self.txs.get(h).map_or(0, |e| u64::from(e.size_bytes)),
        }
    }

    /// Clique's recent-signer rule: whether `signer` sealed one of the last floor(N/2) blocks
    /// of the chain ending at `parent` (so that it may not seal a child of `parent`). False
    /// when `parent` is not stored.
    pub fn signed_recently(&self, parent: &BlockHash, signer: RobotId) -> bool {
        self.blocks.get(parent).is_some_and(|entry| {
            entry
                .recent_signers
                .get((signer / 64) as usize)
                .is_some_and(|word| word & (1u64 << (signer % 64)) != 0)
        })
    }

    /// The recent signers (see [`BlockEntry::recent_signers`]) of a block sealed by `signer`
    /// on the stored block `parent`: the signer itself and the signers of the floor(N/2) - 1
    /// blocks of the chain ending at `parent`, genesis excluded. Walks the ancestors once per
    /// new block.
    fn recent_signers_after(&self, parent: &BlockHash, signer: RobotId) -> Arc<[u64]> {
        let mut bits = vec![0u64; self.robots.div_ceil(64) as usize];
        let mut set = |s: RobotId| {
            if let Some(word) = bits.get_mut((s / 64) as usize) {
                *word |= 1u64 << (s % 64);
            }
        };
        let limit = self.robots / 2;
        if limit > 0 {
            set(signer);
        }
        let mut cursor = *parent;
        for _ in 1..limit {
            let Some(entry) = self.blocks.get(&cursor) else {
                break;
            };
            let header = &entry.block.header;
            if header.height == 0 {
                break;
            }
            set(header.signer);
            cursor = header.parent;
        }
        bits.into()
    }

    /// The difficulty a block at `height` sealed by `signer` must have: 2 in turn (height mod
    /// N == signer), 1 otherwise.
    pub fn expected_difficulty(&self, height: u64, signer: RobotId) -> u64 {
        if height % u64::from(self.robots) == u64::from(signer) {
            2
        } else {
            1
        }
    }

    /// The node's pending transactions that a block on its head may include, in execution
    /// order: per sender the run of consecutive nonces from the next expected one (a duplicate
    /// nonce: the lowest id), senders interleaved by arrival at the node. At most
    /// [`block::MAX_BLOCK_TXS`].
    pub fn sealable_txs(&self, node: RobotId) -> Vec<TxHash> {
        let n = self.node(node);
        let next = &self.blocks[&n.head].next_nonce;
        // Per sender (in id order), the run of consecutive nonces from the next expected one.
        let mut runs: Vec<std::collections::VecDeque<(u64, TxHash)>> = Vec::new();
        let mut current: Option<(RobotId, u64, bool)> = None;
        for (sender, nonce, hash) in n.mempool.by_sender() {
            let (_, expected, open) = match &mut current {
                Some(c) if c.0 == sender => c,
                _ => {
                    runs.push(std::collections::VecDeque::new());
                    current.insert((sender, next[sender as usize], true))
                }
            };
            if !*open {
                continue;
            }
            if nonce == *expected {
                let arrival = n.mempool.arrival(&hash).expect("indexed as pending");
                runs.last_mut().expect("pushed").push_back((arrival, hash));
                *expected += 1;
            } else if nonce > *expected {
                *open = false;
            }
        }
        runs.retain(|run| !run.is_empty());
        let mut out = Vec::new();
        // Header bytes: a generous bound on the encoded header (about 170 bytes).
        let mut bytes = 256u64;
        while out.len() < block::MAX_BLOCK_TXS {
            let best = runs
                .iter()
                .enumerate()
                .filter_map(|(i, r)| r.front().map(|f| (f.0, i)))
                .min();
            let Some((_, i)) = best else { break };
            let hash = runs[i].pop_front().expect("front exists").1;
            let size = u64::from(self.txs[&hash].size_bytes);
            if bytes + size > MAX_BLOCK_BYTES {
                // The rest of this sender's run waits for the next block (nonce order).
                runs[i].clear();
                continue;
            }
            bytes += size;
            out.push(hash);
        }
        out
    }

    /// A transaction from `robot`, signed with its key, with the next nonce in the robot's own
    /// node's view (its chain, then its pending transactions). Driver-side helper: the
    /// transaction enters the ledger with a [`LedgerEvent::Submit`].
    pub fn make_tx(&self, robot: RobotId, value_units: u64, call: Call) -> Tx {
        let n = self.node(robot);
        let mut nonce = self.blocks[&n.head].next_nonce[robot as usize];
        for (p, _) in n.mempool.of_sender(robot) {
            if p == nonce {
                nonce += 1;
            }
        }
        Tx::signed(&self.keys, robot, nonce, value_units, call)
    }

    /// A cheap digest of a node's view (head, mempool, counters).
    pub fn node_digest(&self, node: RobotId) -> Digest {
        self.node(node).digest(node)
    }

    /// A digest of the whole ledger: every node's view, the messages in flight, the time.
    pub fn digest(&self) -> Digest {
        let mut h = blake3::Hasher::new();
        h.update(&self.now.0.to_le_bytes());
        h.update(&self.messages_sent.to_le_bytes());
        h.update(&(self.blocks.len() as u64).to_le_bytes());
        h.update(&(self.txs.len() as u64).to_le_bytes());
        for (seq, f) in &self.flights {
            h.update(&seq.to_le_bytes());
            h.update(&f.from.to_le_bytes());
            h.update(&f.to.to_le_bytes());
        }
        for i in 0..self.robots {
            h.update(&self.node_digest(i).0);
        }
        h.finalize().into()
    }

    /// The ledger's figures for `summary.json`.
    pub fn stats(&self) -> LedgerStats {
        metrics::stats(self)
    }

    // ----- the reducer ---------------------------------------------------------------------

    /// Folds one event at time `at`. A refused item is recorded at its node and is not an
    /// error; an event that cannot happen (unknown node, delivery of a message not in flight,
    /// a sealing against the rules) is an error and leaves the state unchanged.
    pub fn apply(&mut self, at: SimTime, event: &LedgerEvent) -> Result<Applied, LedgerError> {
        if at < self.now {
            return Err(LedgerError::TimeWentBack { at, now: self.now });
        }
        self.check_event(event)?;
        // A sealing is built and validated before anything changes.
        let sealed = match event {
            LedgerEvent::Seal { node, txs, .. } => {
                Some(self.build_seal(*node, txs, at).map_err(|reason| {
                    LedgerError::InvalidSeal {
                        node: *node,
                        reason,
                    }
                })?)
            }
            _ => None,
        };
        self.metrics.sample_until(at, &self.nodes, &self.blocks);
        self.now = at;
        let mut applied = Applied::default();
        match event {
            LedgerEvent::Submit { tx } => {
                let hash = self.store_tx(tx);
                self.metrics
                    .on_submit(hash, tx, self.txs[&hash].size_bytes, at);
                self.receive_tx(tx.sender, hash, at, &mut applied);
            }
            LedgerEvent::Seal { node, .. } => {
                let (hash, entry) = sealed.expect("built above");
                self.insert_valid(hash, entry);
                self.accept_block(*node, hash, at, &mut applied);
            }
            LedgerEvent::Send {
                from,
                to,
                items,
                lost,
            } => {
                let seq = self.messages_sent;
                self.messages_sent += 1;
                let bytes: u64 = items.iter().map(|i| self.item_bytes(i)).sum();
                self.metrics.on_send(bytes, *lost);
                if !lost {
                    self.flights.insert(
                        seq,
                        Flight {
                            from: *from,
                            to: *to,
                            items: items.clone(),
                        },
                    );
                }
            }
            LedgerEvent::Deliver { message } => {
                let flight = self
                    .flights
                    .remove(message)
                    .expect("checked in check_event");
                for item in &flight.items {
                    match item {
                        ItemRef::Block(h) => self.receive_block(flight.to, *h, at, &mut applied),
                        ItemRef::Tx(h) => self.receive_tx(flight.to, *h, at, &mut applied),
                    }
                }
                self.nodes[flight.to as usize].version += 1;
            }
            LedgerEvent::Inject { node, bytes } => self.inject(*node, bytes, at, &mut applied),
            LedgerEvent::Restart { node } => {
                let n = &mut self.nodes[*node as usize];
                n.mempool.clear();
                n.head_since = at;
                n.version += 1;
                self.head_journal.push(*node);
                self.flights.retain(|_, f| f.to != *node);
                applied.head_changes += 1;
            }
        }
        Ok(applied)
    }

    /// Every check that can make an event an error, before anything changes.
    fn check_event(&self, event: &LedgerEvent) -> Result<(), LedgerError> {
        let node_ok = |node: RobotId| {
            if node < self.robots {
                Ok(())
            } else {
                Err(LedgerError::UnknownNode {
                    node,
                    robots: self.robots,
                })
            }
        };
        match event {
            LedgerEvent::Submit { tx } => node_ok(tx.sender),
            LedgerEvent::Seal { node, parent, txs } => {
                node_ok(*node)?;
                let n = self.node(*node);
                if *parent != n.head {
                    return Err(LedgerError::SealNotOnHead {
                        node: *node,
                        parent: *parent,
                        head: n.head,
                    });
                }
                for h in txs {
                    if !self.holds_tx(*node, h) {
                        return Err(LedgerError::UnknownItem {
                            node: *node,
                            item: ItemRef::Tx(*h),
                        });
                    }
                }
                Ok(())
            }
            LedgerEvent::Send {
                from, to, items, ..
            } => {
                node_ok(*from)?;
                node_ok(*to)?;
                if from == to || items.is_empty() {
                    return Err(LedgerError::BadMessage {
                        from: *from,
                        to: *to,
                        why: "a message goes to another node and carries at least one item".into(),
                    });
                }
                let n = self.node(*from);
                for item in items {
                    let known = match item {
                        ItemRef::Block(h) => n.known_blocks.contains(h),
                        ItemRef::Tx(h) => self.holds_tx(*from, h),
                    };
                    if !known {
                        return Err(LedgerError::UnknownItem {
                            node: *from,
                            item: *item,
                        });
                    }
                }
                Ok(())
            }
            LedgerEvent::Deliver { message } => {
                if self.flights.contains_key(message) {
                    Ok(())
                } else {
                    Err(LedgerError::UnknownMessage { message: *message })
                }
            }
            LedgerEvent::Inject { node, .. } | LedgerEvent::Restart { node } => node_ok(*node),
        }
    }

    /// A transaction's storage entry with its intrinsic checks (sender, size, signature).
    fn tx_entry(&self, tx: &Tx, size: usize) -> TxEntry {
        let intrinsic = if tx.sender >= self.robots {
            Err(RejectReason::UnknownSender(tx.sender))
        } else if size > tx::MAX_TX_BYTES {
            Err(RejectReason::Malformed(format!(
                "{size} bytes, more than the {} allowed",
                tx::MAX_TX_BYTES
            )))
        } else if !tx.signature_ok(&self.keys) {
            Err(RejectReason::BadSignature)
        } else {
            Ok(())
        };
        TxEntry {
            tx: Arc::new(tx.clone()),
            size_bytes: size as u32,
            intrinsic,
            held_by: vec![0u64; self.robots.div_ceil(64) as usize].into(),
        }
    }

    /// Stores a transaction (once) with its intrinsic checks; returns its id.
    fn store_tx(&mut self, tx: &Tx) -> TxHash {
        let bytes = tx.encode();
        let hash = Digest::of(&bytes);
        if !self.txs.contains_key(&hash) {
            let entry = self.tx_entry(tx, bytes.len());
            self.txs.insert(hash, entry);
        }
        hash
    }

    fn reject(
        &mut self,
        node: RobotId,
        item: Option<ItemRef>,
        reason: RejectReason,
        at: SimTime,
        applied: &mut Applied,
    ) {
        self.metrics.on_reject(&reason);
        if let Some(ItemRef::Tx(hash)) = item {
            if !self.holds_tx(node, &hash) {
                self.remember_refused(node, hash);
            }
        }
        let n = &mut self.nodes[node as usize];
        n.rejections.push_back(Rejection { at, item, reason });
        if n.rejections.len() > MAX_REJECTIONS_KEPT {
            n.rejections.pop_front();
        }
        n.rejected_total += 1;
        n.version += 1;
        applied.rejected += 1;
    }

    /// A node learns of a stored transaction: intrinsic checks, nonce against its chain, then
    /// the mempool's bounds (replacement rule, per-sender cap, global cap with eviction). Only
    /// an admitted transaction becomes known; a refused one is remembered (bounded) as refused.
    fn receive_tx(&mut self, node: RobotId, hash: TxHash, at: SimTime, applied: &mut Applied) {
        if self.knows_tx(node, &hash) {
            applied.duplicates += 1;
            return;
        }
        let n = &self.nodes[node as usize];
        let entry = &self.txs[&hash];
        let item = Some(ItemRef::Tx(hash));
        if let Err(reason) = &entry.intrinsic {
            let reason = reason.clone();
            return self.reject(node, item, reason, at, applied);
        }
        let (sender, nonce) = (entry.tx.sender, entry.tx.nonce);
        let expected = self.blocks[&n.head].next_nonce[sender as usize];
        if nonce < expected {
            let reason = RejectReason::ReplayedNonce { nonce, expected };
            return self.reject(node, item, reason, at, applied);
        }
        if nonce > expected + MAX_NONCE_GAP {
            let reason = RejectReason::NonceGap { nonce, expected };
            return self.reject(node, item, reason, at, applied);
        }
        // The sender's pending transactions, and the one with the same nonce (the lowest id
        // if several), if any.
        let mine_len = n.mempool.count_of(sender) as usize;
        let same = n.mempool.lowest_with_nonce(sender, nonce);
        let mut evict = None;
        if let Some(same) = same {
            if same < hash {
                return self.reject(node, item, RejectReason::NonceTaken { nonce }, at, applied);
            }
            evict = Some((same, true));
        } else if mine_len as u32 >= MEMPOOL_PER_SENDER {
            let reason = RejectReason::SenderCap {
                sender,
                pending: mine_len as u32,
            };
            return self.reject(node, item, reason, at, applied);
        } else if n.mempool.len() as u32 >= MEMPOOL_MAX {
            // The sender with the most pending (the highest id on ties) gives up its highest
            // nonce, if it has more pending than this sender would have.
            let (victim, count) = n.mempool.busiest().expect("a full mempool has senders");
            if count as usize <= mine_len + 1 {
                let reason = RejectReason::MempoolFull {
                    pending: n.mempool.len() as u32,
                };
                return self.reject(node, item, reason, at, applied);
            }
            let highest = n
                .mempool
                .of_sender(victim)
                .next_back()
                .expect("the busiest sender has pending transactions")
                .1;
            evict = Some((highest, false));
        }
        if let Some((old, replaced)) = evict {
            // A replaced or evicted transaction leaves the node (as in geth's pool): it is no
            // longer known, so a flood of admitted-then-evicted transactions cannot grow the
            // node's memory. It joins the bounded refused set, so that peers do not send it
            // again at once; it becomes known again if a block carries it.
            self.nodes[node as usize].mempool.remove(&old);
            self.release_tx(node, &old);
            self.remember_refused(node, old);
            let n = &mut self.nodes[node as usize];
            if replaced {
                n.mempool_replaced += 1;
            } else {
                n.mempool_evicted += 1;
            }
        }
        self.hold_tx(node, &hash);
        let n = &mut self.nodes[node as usize];
        n.version += 1;
        n.mempool.insert(hash, sender, nonce, n.arrivals);
        n.arrivals += 1;
        applied.accepted += 1;
        self.metrics.on_seen(&hash, node, at);
    }

    /// The checks of a header against its parent that need no body: signer, height,
    /// timestamp, difficulty, recent signers, then the signature. Cheap (one signature check)
    /// and done before any work on the body.
    fn validate_header(&self, header: &BlockHeader) -> Result<&BlockEntry, RejectReason> {
        let parent = self
            .blocks
            .get(&header.parent)
            .ok_or(RejectReason::UnknownParent(header.parent))?;
        let ph = &parent.block.header;
        if header.signer >= self.robots {
            return Err(RejectReason::UnauthorisedSigner(header.signer));
        }
        if header.height != ph.height + 1 {
            return Err(RejectReason::BadHeight {
                got: header.height,
                expected: ph.height + 1,
            });
        }
        let earliest_ms = ph.timestamp_ms + self.period_ms;
        if header.timestamp_ms < earliest_ms {
            return Err(RejectReason::TooEarly {
                got_ms: header.timestamp_ms,
                earliest_ms,
            });
        }
        let expected = self.expected_difficulty(header.height, header.signer);
        if header.difficulty != expected {
            return Err(RejectReason::BadDifficulty {
                got: header.difficulty,
                expected,
            });
        }
        if self.signed_recently(&header.parent, header.signer) {
            return Err(RejectReason::RecentSigner(header.signer));
        }
        if !self
            .keys
            .verify(header.signer, &header.signing_hash(), &header.signature)
        {
            return Err(RejectReason::BadSignature);
        }
        Ok(parent)
    }

    /// Validates a block against its parent: header rules and signature first, then the body
    /// (root, count, byte limit, each transaction stored or in `fresh`, intrinsically valid,
    /// with the next nonce of its sender) and execution. Pure.
    fn validate(
        &self,
        header: &BlockHeader,
        txs: &[TxHash],
        fresh: &BTreeMap<TxHash, TxEntry>,
    ) -> Result<BlockEntry, RejectReason> {
        let parent = self.validate_header(header)?;
        let ph = &parent.block.header;
        if txs.len() > block::MAX_BLOCK_TXS {
            return Err(RejectReason::Malformed(format!(
                "{} transactions, more than the {} allowed",
                txs.len(),
                block::MAX_BLOCK_TXS
            )));
        }
        if header.tx_root != block::tx_root(txs) {
            return Err(RejectReason::BadTxRoot);
        }
        let mut size_bytes = u64::from(header.hash_and_size().1);
        for hash in txs {
            size_bytes += self
                .txs
                .get(hash)
                .or_else(|| fresh.get(hash))
                .map_or(0, |e| u64::from(e.size_bytes));
        }
        if size_bytes > MAX_BLOCK_BYTES {
            return Err(RejectReason::Oversize {
                bytes: size_bytes,
                limit: MAX_BLOCK_BYTES,
            });
        }
        let mut state = parent.state.clone();
        let epoch = self.enter_block(&mut state, ph.timestamp_ms, header.timestamp_ms);
        let params = &self.epochs[epoch].params;
        let mut next_nonce = parent.next_nonce.to_vec();
        let mut receipts = Vec::with_capacity(txs.len());
        for (index, hash) in txs.iter().enumerate() {
            let bad = |reason| RejectReason::BadTx {
                index: index as u32,
                reason: Box::new(reason),
            };
            let entry = self
                .txs
                .get(hash)
                .or_else(|| fresh.get(hash))
                .ok_or_else(|| bad(RejectReason::Malformed("unknown transaction".into())))?;
            entry.intrinsic.clone().map_err(bad)?;
            let tx = &entry.tx;
            let expected = next_nonce[tx.sender as usize];
            if tx.nonce < expected {
                return Err(bad(RejectReason::ReplayedNonce {
                    nonce: tx.nonce,
                    expected,
                }));
            }
            if tx.nonce > expected {
                return Err(bad(RejectReason::NonceGap {
                    nonce: tx.nonce,
                    expected,
                }));
            }
            next_nonce[tx.sender as usize] += 1;
            receipts.push(state.execute(params, tx.sender, tx.value_units, &tx.call));
        }
        Ok(BlockEntry {
            block: Arc::new(Block {
                header: header.clone(),
                txs: txs.to_vec(),
            }),
            size_bytes,
            total_difficulty: parent.total_difficulty + header.difficulty,
            chain_bytes: parent.chain_bytes + size_bytes,
            state_digest: state.digest(),
            state,
            recent_signers: self.recent_signers_after(&header.parent, header.signer),
            next_nonce: next_nonce.into(),
            receipts: receipts.into(),
            children: 0,
        })
    }

    /// The block `node` seals on its head at `at` with `txs`, validated.
    fn build_seal(
        &self,
        node: RobotId,
        txs: &[TxHash],
        at: SimTime,
    ) -> Result<(BlockHash, BlockEntry), RejectReason> {
        let n = self.node(node);
        let height = n.canonical.len() as u64;
        let mut header = BlockHeader {
            parent: n.head,
            height,
            timestamp_ms: self.clock_ms(node, at),
            signer: node,
            difficulty: self.expected_difficulty(height, node),
            tx_root: block::tx_root(txs),
            signature: Sig::ZERO,
        };
        header.signature = self.keys.sign(node, &header.signing_hash());
        let entry = self.validate(&header, txs, &BTreeMap::new())?;
        Ok((header.hash_and_size().0, entry))
    }

    fn insert_valid(&mut self, hash: BlockHash, entry: BlockEntry) {
        if self.blocks.contains_key(&hash) {
            return;
        }
        let parent = entry.block.header.parent;
        self.sealed_on
            .entry((parent, entry.block.header.signer))
            .or_default()
            .push(hash);
        self.blocks.insert(hash, entry);
        self.blocks
            .get_mut(&parent)
            .expect("a valid block's parent is stored")
            .children += 1;
    }

    /// A node receives a stored valid block by id (gossip).
    fn receive_block(
        &mut self,
        node: RobotId,
        hash: BlockHash,
        at: SimTime,
        applied: &mut Applied,
    ) {
        let n = &self.nodes[node as usize];
        if n.known_blocks.contains(&hash) {
            applied.duplicates += 1;
            return;
        }
        let header = &self.blocks[&hash].block.header;
        if !n.known_blocks.contains(&header.parent) {
            let reason = RejectReason::UnknownParent(header.parent);
            return self.reject(node, Some(ItemRef::Block(hash)), reason, at, applied);
        }
        let now_ms = self.clock_ms(node, at);
        if header.timestamp_ms > now_ms {
            let reason = RejectReason::FutureBlock {
                got_ms: header.timestamp_ms,
                now_ms,
            };
            return self.reject(node, Some(ItemRef::Block(hash)), reason, at, applied);
        }
        self.accept_block(node, hash, at, applied);
    }

    /// Foreign bytes arrive at a node. Cheapest checks first, and nothing is stored before
    /// it is known valid: the length, the decoding, then for a block its id (known, or cached
    /// as invalid), its parent, its timestamp against the node's clock, its header rules and
    /// signature, and only then its body (hashes, root, limits, execution); for a transaction,
    /// its intrinsic checks. Only a valid block's transactions, and a transaction that passes
    /// its intrinsic checks, enter the shared storage.
    fn inject(&mut self, node: RobotId, bytes: &[u8], at: SimTime, applied: &mut Applied) {
        if bytes.len() > MAX_WIRE_BYTES {
            let reason = RejectReason::Oversize {
                bytes: bytes.len() as u64,
                limit: MAX_WIRE_BYTES as u64,
            };
            return self.reject(node, None, reason, at, applied);
        }
        let item: WireItem = match rmp_serde::from_slice(bytes) {
            Ok(item) => item,
            Err(e) => {
                return self.reject(
                    node,
                    None,
                    RejectReason::Undecodable(e.to_string()),
                    at,
                    applied,
                )
            }
        };
        match item {
            WireItem::Tx(tx) => {
                let encoded = tx.encode();
                let hash = Digest::of(&encoded);
                if self.txs.contains_key(&hash) {
                    return self.receive_tx(node, hash, at, applied);
                }
                // Not stored, so not held: only a refusal can make it known.
                if self.nodes[node as usize].refused_txs.contains(&hash) {
                    applied.duplicates += 1;
                    return;
                }
                let entry = self.tx_entry(&tx, encoded.len());
                if let Err(reason) = entry.intrinsic {
                    return self.reject(node, Some(ItemRef::Tx(hash)), reason, at, applied);
                }
                self.txs.insert(hash, entry);
                self.receive_tx(node, hash, at, applied);
            }
            WireItem::Block(wire) => {
                let (hash, _) = wire.header.hash_and_size();
                let item = Some(ItemRef::Block(hash));
                if self.nodes[node as usize].known_blocks.contains(&hash) {
                    applied.duplicates += 1;
                    return;
                }
                if let Some(reason) = self.invalid_blocks.get(&hash) {
                    let reason = reason.clone();
                    return self.reject(node, item, reason, at, applied);
                }
                if !self.blocks.contains_key(&hash) {
                    if !self.nodes[node as usize]
                        .known_blocks
                        .contains(&wire.header.parent)
                    {
                        let reason = RejectReason::UnknownParent(wire.header.parent);
                        return self.reject(node, item, reason, at, applied);
                    }
                    let now_ms = self.clock_ms(node, at);
                    if wire.header.timestamp_ms > now_ms {
                        let reason = RejectReason::FutureBlock {
                            got_ms: wire.header.timestamp_ms,
                            now_ms,
                        };
                        return self.reject(node, item, reason, at, applied);
                    }
                    let checked = if wire.txs.len() > block::MAX_BLOCK_TXS {
                        Err(RejectReason::Malformed(format!(
                            "{} transactions, more than the {} allowed",
                            wire.txs.len(),
                            block::MAX_BLOCK_TXS
                        )))
                    } else {
                        self.validate_header(&wire.header).map(|_| ())
                    };
                    let result = checked.and_then(|()| {
                        let mut fresh = BTreeMap::new();
                        let mut ids = Vec::with_capacity(wire.txs.len());
                        for tx in &wire.txs {
                            let encoded = tx.encode();
                            let id = Digest::of(&encoded);
                            if !self.txs.contains_key(&id) {
                                fresh.insert(id, self.tx_entry(tx, encoded.len()));
                            }
                            ids.push(id);
                        }
                        self.validate(&wire.header, &ids, &fresh)
                            .map(|entry| (entry, fresh))
                    });
                    match result {
                        Ok((entry, fresh)) => {
                            self.txs.extend(fresh);
                            self.insert_valid(hash, entry);
                        }
                        Err(reason) => {
                            // A body that does not match the header's root says nothing about
                            // the header (whose id is the block's): never cached, so that a
                            // forged body cannot poison the honest block's id.
                            if reason.is_intrinsic() {
                                self.invalid_blocks.insert(hash, reason.clone());
                                self.invalid_order.push_back(hash);
                                if self.invalid_order.len() > MAX_INVALID_CACHE {
                                    let old = self.invalid_order.pop_front().expect("not empty");
                                    self.invalid_blocks.remove(&old);
                                }
                            }
                            return self.reject(node, item, reason, at, applied);
                        }
                    }
                }
                self.receive_block(node, hash, at, applied);
            }
        }
    }

    /// Adds a valid block whose parent the node knows to the node's tree; fork choice.
    fn accept_block(&mut self, node: RobotId, hash: BlockHash, at: SimTime, applied: &mut Applied) {
        let entry = &self.blocks[&hash];
        let header = entry.block.header.clone();
        let td = entry.total_difficulty;
        let size_bytes = entry.size_bytes;
        let tx_ids = entry.block.txs.clone();
        let n = &mut self.nodes[node as usize];
        assert!(
            n.known_blocks.contains(&header.parent),
            "accepting a block whose parent is unknown"
        );
        n.known_blocks.insert(hash);
        n.stored_bytes += size_bytes;
        n.version += 1;
        applied.accepted += 1;
        for tx in &tx_ids {
            if self.hold_tx(node, tx) {
                self.metrics.on_seen(tx, node, at);
            }
        }
        // Equivocation: another block the same signer sealed on the same parent, known here.
        // An honest sealer never seals twice on one parent (its head moves to its own child,
        // which is heavier than the parent), so this is evidence, not a coincidence.
        let twin = self
            .sealed_on
            .get(&(header.parent, header.signer))
            .and_then(|v| {
                v.iter()
                    .find(|h| **h != hash && self.nodes[node as usize].known_blocks.contains(*h))
                    .copied()
            });
        let n = &mut self.nodes[node as usize];
        if let Some(twin) = twin {
            if n.evidence.len() < MAX_EVIDENCE {
                n.evidence
                    .entry((header.signer, header.parent))
                    .or_insert((twin.min(hash), twin.max(hash)));
            }
        }
        if header.parent != n.head {
            n.side_blocks += 1;
        }
        n.by_td.entry(td).or_default().push(hash);
        // Fork choice: the greatest total difficulty; a tie keeps the current head...
        if td > self.blocks[&n.head].total_difficulty {
            self.set_head(node, hash, at);
            applied.head_changes += 1;
        }
        // ...unless the node may not seal on it (see `unstick`).
        if self.unstick(node, at) {
            applied.head_changes += 1;
        }
    }

    /// Liveness under Clique's recent-signer rule. A node that may not seal on its head moves
    /// to an equally heavy known block on which it may (the lowest id if several). Without
    /// this, equally heavy branches whose every node signed recently on its own branch
    /// deadlock forever under "ties keep the head" (geth's Clique has the same hole: it breaks
    /// ties by lower height, then by a coin flip); the property test found such a deadlock
    /// with 4 robots. With it, some node can always seal, so connected nodes converge. The
    /// rule changes nothing while a node may seal on its head. Returns whether the head moved.
    fn unstick(&mut self, node: RobotId, at: SimTime) -> bool {
        let n = &self.nodes[node as usize];
        if !self.signed_recently(&n.head, node) {
            return false;
        }
        let td = self.blocks[&n.head].total_difficulty;
        let better = n.by_td.get(&td).and_then(|same| {
            same.iter()
                .filter(|h| **h != n.head && !self.signed_recently(h, node))
                .min()
                .copied()
        });
        match better {
            Some(b) => {
                self.set_head(node, b, at);
                true
            }
            None => false,
        }
    }

    /// Moves the node's head to `new_head`: canonical chain, reorg figures, mempool.
    fn set_head(&mut self, node: RobotId, new_head: BlockHash, at: SimTime) {
        // The branch from the new head down to the first block of the old canonical chain.
        let mut branch = Vec::new();
        let mut cursor = new_head;
        loop {
            let h = self.blocks[&cursor].block.header.height as usize;
            let canonical = &self.nodes[node as usize].canonical;
            if h < canonical.len() && canonical[h] == cursor {
                break;
            }
            branch.push(cursor);
            cursor = self.blocks[&cursor].block.header.parent;
        }
        let ancestor_height = self.blocks[&cursor].block.header.height as usize;
        let n = &mut self.nodes[node as usize];
        let abandoned: Vec<BlockHash> = n.canonical.split_off(ancestor_height + 1);
        let depth = abandoned.len() as u64;
        if depth > 0 {
            n.reorgs += 1;
            n.deepest_reorg = n.deepest_reorg.max(depth);
            self.metrics.on_reorg(depth);
        }
        n.canonical.extend(branch.iter().rev());
        n.head = new_head;
        n.head_td = self.blocks[&new_head].total_difficulty;
        n.head_since = at;
        n.version += 1;
        self.head_journal.push(node);
        // Transactions of abandoned blocks return to the mempool; then the mempool keeps only
        // what is still pending on the new chain.
        for b in &abandoned {
            for tx in &self.blocks[b].block.txs {
                let n = &mut self.nodes[node as usize];
                if !n.mempool.contains(tx) {
                    let body = &self.txs[tx].tx;
                    n.mempool.insert(*tx, body.sender, body.nonce, n.arrivals);
                    n.arrivals += 1;
                }
            }
        }
        let next = self.blocks[&new_head].next_nonce.clone();
        self.nodes[node as usize].mempool.retain_from_nonces(&next);
        for b in branch.iter().rev() {
            for tx in &self.blocks[b].block.txs {
                if self.txs[tx].tx.sender == node {
                    self.metrics.on_included_own(tx, at);
                }
            }
        }
    }

    // ----- checks --------------------------------------------------------------------------

    /// Re-derives the contract state of a chain (genesis first) from scratch, without any
    /// cache: every transaction executed again in order.
    pub fn replay_state(&self, chain: &[BlockHash]) -> Result<ContractState, String> {
        let mut state = ContractState::genesis(self.params());
        let mut parent_ms = 0;
        for (i, hash) in chain.iter().enumerate() {
            let entry = self
                .blocks
                .get(hash)
                .ok_or_else(|| format!("block {i} ({hash:?}) is not stored"))?;
            let timestamp_ms = entry.block.header.timestamp_ms;
            let params = &self.epochs[self.enter_block(&mut state, parent_ms, timestamp_ms)].params;
            parent_ms = timestamp_ms;
            for tx in &entry.block.txs {
                let tx = &self
                    .txs
                    .get(tx)
                    .ok_or_else(|| format!("transaction {tx:?} is not stored"))?
                    .tx;
                state.execute(params, tx.sender, tx.value_units, &tx.call);
            }
        }
        Ok(state)
    }

    /// Checks one stored block against its parent from scratch, without any cache: linkage,
    /// every Clique rule, the signatures (verified again), the byte and count limits, the
    /// transaction root, the nonces, and the contract state after it against a fresh
    /// execution of its transactions on the parent's state (which conserves tokens).
    pub fn check_block(&self, hash: &BlockHash) -> Result<(), String> {
        let entry = self
            .blocks
            .get(hash)
            .ok_or_else(|| format!("block {hash:?} is not stored"))?;
        let h = &entry.block.header;
        if h.height == 0 {
            return if *hash == self.genesis {
                Ok(())
            } else {
                Err("a second genesis".into())
            };
        }
        let fail = |what: &str| {
            Err(format!(
                "block {} at height {}: {what}",
                hash.short(),
                h.height
            ))
        };
        let Some(parent) = self.blocks.get(&h.parent) else {
            return fail("parent not stored");
        };
        let ph = &parent.block.header;
        if h.height != ph.height + 1 || h.hash_and_size().0 != *hash {
            return fail("broken linkage");
        }
        if h.signer >= self.robots || !self.keys.verify(h.signer, &h.signing_hash(), &h.signature) {
            return fail("bad signer or signature");
        }
        if h.timestamp_ms < ph.timestamp_ms + self.period_ms {
            return fail("sealed before the period elapsed");
        }
        if h.difficulty != self.expected_difficulty(h.height, h.signer) {
            return fail("wrong difficulty");
        }
        let mut cursor = h.parent;
        for _ in 0..self.robots / 2 {
            let c = &self.blocks[&cursor].block.header;
            if c.height == 0 {
                break;
            }
            if c.signer == h.signer {
                return fail("recent signer sealed again");
            }
            cursor = c.parent;
        }
        // The cached recent signers against a walk of the block's own chain.
        let mut recent = vec![0u64; self.robots.div_ceil(64) as usize];
        let mut cursor = *hash;
        for _ in 0..self.robots / 2 {
            let c = &self.blocks[&cursor].block.header;
            if c.height == 0 {
                break;
            }
            if let Some(word) = recent.get_mut((c.signer / 64) as usize) {
                *word |= 1u64 << (c.signer % 64);
            }
            cursor = c.parent;
        }
        if recent[..] != entry.recent_signers[..] {
            return fail("cached recent signers differ from the chain's");
        }
        if h.tx_root != block::tx_root(&entry.block.txs) {
            return fail("transaction root mismatch");
        }
        if entry.block.txs.len() > block::MAX_BLOCK_TXS || entry.size_bytes > MAX_BLOCK_BYTES {
            return fail("over the block limits");
        }
        let mut state = parent.state.clone();
        let epoch = self.enter_block(&mut state, ph.timestamp_ms, h.timestamp_ms);
        let params = &self.epochs[epoch].params;
        let mut nonces = parent.next_nonce.to_vec();
        for tx in &entry.block.txs {
            let Some(stored) = self.txs.get(tx) else {
                return fail("transaction not stored");
            };
            let tx = &stored.tx;
            if tx.sender >= self.robots
                || !tx.signature_ok(&self.keys)
                || tx.nonce != nonces[tx.sender as usize]
            {
                return fail("bad transaction signature or nonce");
            }
            nonces[tx.sender as usize] += 1;
            state.execute(params, tx.sender, tx.value_units, &tx.call);
        }
        if state.digest() != entry.state.digest()
            || entry.state_digest != entry.state.digest()
            || nonces[..] != entry.next_nonce[..]
        {
            return fail("contract state differs from a fresh execution");
        }
        if entry.total_difficulty != parent.total_difficulty + h.difficulty {
            return fail("total difficulty");
        }
        Ok(())
    }

    /// Checks a node's canonical chain from scratch: linkage, every Clique rule, every
    /// signature (verified again, not from the cache), nonces, transaction roots, and the
    /// contract state after every block against a fresh re-execution.
    pub fn check_chain(&self, node: RobotId) -> Result<(), String> {
        let chain = self.canonical_chain(node);
        if chain.first() != Some(&self.genesis) {
            return Err("the chain does not start at genesis".into());
        }
        if chain.last() != Some(&self.node(node).head) {
            return Err("the chain does not end at the head".into());
        }
        let mut state = ContractState::genesis(self.params());
        let mut nonces = vec![0u64; self.robots as usize];
        let mut td = 0u64;
        let mut recent: Vec<RobotId> = Vec::new();
        for (height, pair) in chain.windows(2).enumerate() {
            let height = height as u64 + 1;
            let (parent, child) = (&self.blocks[&pair[0]], &self.blocks[&pair[1]]);
            let h = &child.block.header;
            let fail = |what: &str| Err(format!("node {node}, height {height}: {what}"));
            if h.parent != pair[0] || h.height != height || h.hash_and_size().0 != pair[1] {
                return fail("broken linkage");
            }
            if h.signer >= self.robots
                || !self.keys.verify(h.signer, &h.signing_hash(), &h.signature)
            {
                return fail("bad signer or signature");
            }
            if h.timestamp_ms < parent.block.header.timestamp_ms + self.period_ms {
                return fail("sealed before the period elapsed");
            }
            if h.difficulty != self.expected_difficulty(height, h.signer) {
                return fail("wrong difficulty");
            }
            let window = (self.robots / 2) as usize;
            if recent.iter().rev().take(window).any(|&s| s == h.signer) {
                return fail("recent signer sealed again");
            }
            recent.push(h.signer);
            if h.tx_root != block::tx_root(&child.block.txs) {
                return fail("transaction root mismatch");
            }
            let epoch =
                self.enter_block(&mut state, parent.block.header.timestamp_ms, h.timestamp_ms);
            let params = &self.epochs[epoch].params;
            for tx in &child.block.txs {
                let tx = &self.txs[tx].tx;
                if !tx.signature_ok(&self.keys) || tx.nonce != nonces[tx.sender as usize] {
                    return fail("bad transaction signature or nonce");
                }
                nonces[tx.sender as usize] += 1;
                state.execute(params, tx.sender, tx.value_units, &tx.call);
            }
            td += h.difficulty;
            if td != child.total_difficulty || state.digest() != child.state.digest() {
                return fail("total difficulty or contract state differs from a fresh replay");
            }
        }
        Ok(())
    }
}

/// The set of every node's known block ids (tests and metrics).
pub fn known_block_union(ledger: &Ledger) -> BTreeSet<BlockHash> {
    (0..ledger.robots())
        .flat_map(|i| ledger.node(i).known_blocks.iter().copied())
        .collect()
}

#[cfg(test)]
mod tests;

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

mod apply;
mod audit;
pub mod block;
pub mod evidence;
mod fork_choice;
pub mod geth;
mod intake;
mod journal;
pub mod keys;
pub mod metrics;
pub mod network;
pub mod node;
mod pending;
mod seal;
pub mod synthetic;
pub mod tx;
mod validate;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

pub use block::{Block, BlockHash, BlockHeader, WireBlock, WireItem};
pub use evidence::Evidence;
pub use keys::{Keys, Sig};
pub use metrics::{EquivocationStat, LedgerStats, VersionPropagation};
pub use network::Network;
pub use node::{Node, RejectReason, Rejection};
pub use tx::{Tx, TxHash};

use journal::HeadJournal;

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
    /// time, carrying the proofs of the equivocations named by `evidence`. Difficulty, height
    /// and signature follow from the rules and the node's key.
    Seal {
        /// The sealing node.
        node: RobotId,
        /// Its head (checked).
        parent: BlockHash,
        /// Transaction ids, in execution order; the node must know them.
        txs: Vec<TxHash>,
        /// Equivocations the block proves, each as the pair of twin block ids (lower id first)
        /// the node holds as evidence ([`Node::evidence`]); absent from the record when empty,
        /// so honest runs' records do not change.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        evidence: Vec<(BlockHash, BlockHash)>,
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
    /// last floor(S/2) blocks of the chain ending with this one (genesis excluded), S the
    /// signers authorised after it (N until a removal, see `removed_signers`). One bit
    /// per robot, computed once, so that [`Ledger::signed_recently`] costs one lookup instead
    /// of a walk of up to N/2 ancestors.
    pub recent_signers: Arc<[u64]>,
    /// The sealers removed from the signer set on the chain ending with this block, one bit
    /// per robot: those against which the block or an ancestor carried evidence
    /// (`ledger/evidence.rs`). They may not seal its children. All zero (shared with genesis)
    /// while nobody is removed.
    pub removed_signers: Arc<[u64]>,
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
    /// How many stored blocks and messages in flight carry the transaction. With `held_by`,
    /// what keeps it stored: when neither any node holds it nor anything carries it, it leaves
    /// the storage (see `Ledger::drop_if_unused`), so refused variants cannot grow it.
    carried_by: u32,
}

impl TxEntry {
    /// Whether `node` holds the transaction (pending, or in a block it knows).
    pub fn held_by(&self, node: RobotId) -> bool {
        self.held_by
            .get((node / 64) as usize)
            .is_some_and(|word| word & (1u64 << (node % 64)) != 0)
    }

    /// Whether no node holds the transaction and no stored block or message in flight
    /// carries it.
    fn unused(&self) -> bool {
        self.carried_by == 0 && self.held_by.iter().all(|word| *word == 0)
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
            evidence: Vec::new(),
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
            removed_signers: vec![0u64; robots.div_ceil(64) as usize].into(),
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

    /// A transaction from `robot`, signed with its key, with the next nonce in the robot's own
    /// node's view (its chain, then its pending transactions). Driver-side helper: the
    /// transaction enters the ledger with a [`LedgerEvent::Submit`].
    pub fn make_tx(&self, robot: RobotId, value_units: u64, call: Call) -> Tx {
        self.make_tx_with_gas(robot, value_units, call, None)
    }

    /// [`Ledger::make_tx`] carrying its own gas estimate and limit when `gas` is given
    /// (`contract.gas_limit = "estimate"`).
    pub fn make_tx_with_gas(
        &self,
        robot: RobotId,
        value_units: u64,
        call: Call,
        gas: Option<crate::contract::gas_limit::TxGas>,
    ) -> Tx {
        let n = self.node(robot);
        let mut nonce = self.blocks[&n.head].next_nonce[robot as usize];
        for (p, _) in n.mempool.of_sender(robot) {
            if p == nonce {
                nonce += 1;
            }
        }
        Tx::signed_with_gas(&self.keys, robot, nonce, value_units, call, gas)
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
}

/// The set of every node's known block ids (tests and metrics).
pub fn known_block_union(ledger: &Ledger) -> BTreeSet<BlockHash> {
    (0..ledger.robots())
        .flat_map(|i| ledger.node(i).known_blocks.iter().copied())
        .collect()
}

#[cfg(test)]
mod tests;

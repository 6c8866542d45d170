//! Byzantine robots on the ledger (`byzantine.ledger`), orthogonal to the model attacks of
//! `byzantine.kind`: the same robots (see [`super::byzantine_robots`]) may forge models, attack
//! the chain, or both.
//!
//! A Byzantine robot knows what its own node knows (its chain, its mempool, its keys) and acts
//! on the radio as everyone does: what it sends reaches the robots in its range now (the peer
//! sets after faults). Its misbehaviour enters the log as [`LedgerEvent::Inject`]s of encoded
//! items, so replays need no agent; honest nodes check every injected byte. One file per
//! behaviour; each says what honest nodes do about it:
//! - `equivocate`: seals two blocks on one parent (evidence kept per sealer, see
//!   [`crate::ledger::Node::evidence`]; fork choice settles the branch, and the next honest
//!   sealing that holds the evidence carries it, removing the sealer from the signer set);
//! - `withhold`: releases its blocks late to half of its peers (delays and reorgs, bounded by
//!   the withholding time);
//! - `flood`: transaction spam (bounded by the mempool caps and the nonce window);
//! - `replay`: old transactions and transactions signed for another chain (refused: replayed
//!   nonce, bad signature against the chain identity);
//! - `spam-invalid`: garbage, forged signatures, invalid bodies, oversize blocks (refused
//!   before any body work, nothing stored);
//! - `future-timestamp`: blocks stamped an hour ahead (refused against each node's clock, not
//!   stored).

use std::sync::Arc;

use crate::config::{Config, LedgerBehaviour, WithholdPolicy};
use crate::ledger::network::GossipFilter;
use crate::ledger::{BlockHash, BlockHeader, Ledger, LedgerEvent, Sig, Tx, WireBlock, WireItem};
use crate::rng::{self, Purpose, Rng};
use crate::types::{RobotId, SimTime};

/// What a Byzantine robot sees when it acts.
pub struct View<'a> {
    /// Every node (the robot reads only its own node and the shared storage).
    pub ledger: &'a Ledger,
    /// The robot.
    pub robot: RobotId,
    /// Now.
    pub now: SimTime,
    /// The robots in its radio range now, ascending.
    pub peers: &'a [RobotId],
}

/// One ledger misbehaviour: the injections it makes at its occasions.
pub trait Behaviour: Send {
    /// Right after the robot sealed `block` (now its head).
    fn after_seal(&mut self, _view: &View, _block: BlockHash, _rng: &mut Rng) -> Vec<LedgerEvent> {
        Vec::new()
    }

    /// At the end of every tick.
    fn on_tick(&mut self, _view: &View, _rng: &mut Rng) -> Vec<LedgerEvent> {
        Vec::new()
    }
}

/// Writes `mod file;` for each misbehaviour line of the [`LedgerBehaviour`] registry
/// (`config/ledger.rs`: `Flood = "flood" in flood`) and `behaviour`, the `match` from each
/// one to a new agent of the type of its name in its file (`flood::Flood`, [`Default`]). The
/// lines without an agent are handled here by name, so any other line without a file does
/// not compile.
macro_rules! declare_ledger_attacks {
    (LedgerBehaviour: $( $Kind:ident $(in $file:ident)? ),+) => {
        $( $( mod $file; )? )+

        /// A new agent of `kind`; `None` for the kinds that inject nothing.
        fn behaviour(kind: LedgerBehaviour) -> Option<Box<dyn Behaviour>> {
            match kind {
                $( LedgerBehaviour::$Kind => declare_ledger_attacks!(@agent $Kind $($file)?), )+
            }
        }
    };
    // Honest robots have no agent; withholding robots act through the network's gossip filter
    // (`withhold.rs`, [`LedgerAgents::withhold_policy`]) and inject nothing.
    (@agent Honest) => { None };
    (@agent Withhold withhold) => { None };
    (@agent $Kind:ident $file:ident) => { Some(Box::new(<$file::$Kind>::default())) };
}

crate::config::ledger_attack_files!(declare_ledger_attacks);

/// The ledger agents of a run's Byzantine robots (driver side).
pub struct LedgerAgents {
    agents: Vec<(RobotId, Box<dyn Behaviour>, Rng)>,
    withhold: Option<WithholdPolicy>,
}

impl LedgerAgents {
    /// The agents of `config`'s Byzantine robots (none when `byzantine.ledger` is honest).
    pub fn new(config: &Config, seed: u64) -> LedgerAgents {
        let kind = config.byzantine.ledger;
        let byzantine = super::byzantine_robots(config, seed);
        let robots: Vec<RobotId> = (0..config.world.robots)
            .filter(|&r| byzantine[r as usize])
            .collect();
        let agents = robots
            .iter()
            .filter_map(|&r| {
                behaviour(kind).map(|b| (r, b, rng::stream(seed, Purpose::LedgerAttack, r)))
            })
            .collect();
        let withhold = (kind == LedgerBehaviour::Withhold).then(|| {
            WithholdPolicy::new(
                byzantine,
                (config.ledger.block_period_s * 1000.0).round() as u64,
            )
        });
        LedgerAgents { agents, withhold }
    }

    /// The gossip filter of withholding robots, if any.
    pub fn withhold_policy(&self) -> Option<Arc<dyn GossipFilter>> {
        self.withhold
            .clone()
            .map(|policy| Arc::new(policy) as Arc<dyn GossipFilter>)
    }

    /// The injections right after `node` sealed `block` at `now`.
    pub fn after_seal(
        &mut self,
        ledger: &Ledger,
        node: RobotId,
        block: BlockHash,
        now: SimTime,
        peers: &[Vec<RobotId>],
    ) -> Vec<LedgerEvent> {
        let mut out = Vec::new();
        for (robot, agent, rng) in &mut self.agents {
            if *robot == node {
                let view = view(ledger, *robot, now, peers);
                out.extend(agent.after_seal(&view, block, rng));
            }
        }
        out
    }

    /// The injections at the end of the tick ending at `now`, robots in id order. `down`
    /// robots (crashed) do nothing.
    pub fn on_tick(
        &mut self,
        ledger: &Ledger,
        now: SimTime,
        peers: &[Vec<RobotId>],
        down: &dyn Fn(RobotId) -> bool,
    ) -> Vec<LedgerEvent> {
        let mut out = Vec::new();
        for (robot, agent, rng) in &mut self.agents {
            if down(*robot) {
                continue;
            }
            let view = view(ledger, *robot, now, peers);
            out.extend(agent.on_tick(&view, rng));
        }
        out
    }
}

fn view<'a>(
    ledger: &'a Ledger,
    robot: RobotId,
    now: SimTime,
    peers: &'a [Vec<RobotId>],
) -> View<'a> {
    View {
        ledger,
        robot,
        now,
        peers: peers.get(robot as usize).map_or(&[][..], |p| &p[..]),
    }
}

/// A block on `parent` sealed (signed) by `robot` with `txs` at `timestamp_ms`, with the
/// difficulty the rules give it.
pub(crate) fn signed_block(
    ledger: &Ledger,
    robot: RobotId,
    parent: BlockHash,
    timestamp_ms: u64,
    txs: Vec<Tx>,
) -> WireBlock {
    let height = ledger.block(&parent).map_or(0, |e| e.block.header.height) + 1;
    let ids: Vec<_> = txs.iter().map(|t| t.hash_and_size().0).collect();
    let mut header = BlockHeader {
        parent,
        height,
        timestamp_ms,
        signer: robot,
        difficulty: ledger.expected_difficulty(&parent, robot),
        tx_root: crate::ledger::block::tx_root(&ids),
        signature: Sig::ZERO,
        evidence: Vec::new(),
    };
    header.signature = ledger.keys().sign(robot, &header.signing_hash());
    WireBlock { header, txs }
}

/// `item` sent to each of `to`.
pub(crate) fn inject_to(to: &[RobotId], item: &WireItem) -> Vec<LedgerEvent> {
    let bytes = item.encode();
    to.iter()
        .map(|&node| LedgerEvent::Inject {
            node,
            bytes: bytes.clone(),
        })
        .collect()
}

/// Whether `now` crossed a multiple of `period_ms` since the previous tick of `tick_ms`.
pub(crate) fn every(now: SimTime, period_ms: u64, last: &mut u64) -> bool {
    if now.0 >= *last + period_ms {
        *last = now.0;
        true
    } else {
        false
    }
}

#[cfg(test)]
mod tests;

//! How the robots share their models (`learn.aggregation`), as the driver sees it: the one value
//! it asks what to schedule on the radio each tick, what a robot starts its phase from and how
//! its model leaves. The chain runs the ledger's sealing and gossip scheduler ([`Network`]) and
//! the Byzantine nodes' misbehaviour; `gossip` runs the stigmergy's gossip ([`Gossiper`]);
//! `central` needs no scheduler (the ideal server is off the radio).

use std::borrow::Cow;
use std::sync::Arc;

use super::recorder::{Part, Recorder};
use crate::aggregation::{AggregationEvent, Gossiper, StartView};
use crate::byzantine::ledger::LedgerAgents;
use crate::config::{Aggregation, Config};
use crate::contract::{Call, ContractState};
use crate::event::{CheckpointCause, Event};
use crate::faults::FaultSchedule;
use crate::ledger::{LedgerEvent, Network, Tx};
use crate::state::State;
use crate::types::{Digest, RobotId, SimTime};

/// The driver side of the aggregation a run uses.
pub(super) enum Protocol {
    /// The blockchain: models are transactions to the contract on every robot's node.
    Chain(Box<Chain>),
    /// Flow-FL's virtual stigmergy, replicated by neighbour gossip.
    Gossip(Box<Gossiper>),
    /// An ideal server that gets every upload instantly.
    Central,
}

/// The chain's agents: the scheduler of sealings, gossip and deliveries, and the Byzantine
/// robots' ledger misbehaviour.
pub(super) struct Chain {
    network: Network,
    agents: LedgerAgents,
}

/// How a model is submitted: a transaction to the contract, or a baseline's write or upload.
pub(super) enum Submission {
    Tx(Tx),
    Baseline(AggregationEvent),
}

/// What a robot starts a learning phase from, whatever the aggregation: the shared model at
/// its own chain's head, its stigmergy merge, or the server's model.
pub(super) struct Start {
    pub(super) weights: Arc<[i64]>,
    pub(super) digest: Digest,
    pub(super) round: u64,
}

impl From<StartView> for Start {
    fn from(view: StartView) -> Start {
        Start {
            weights: view.weights,
            digest: view.digest,
            round: view.round,
        }
    }
}

/// The radio's part of one tick, from `time` to `now`.
pub(super) struct RadioTick<'a> {
    pub(super) time: SimTime,
    pub(super) now: SimTime,
    /// The radio's peer sets at `now`, with the links the faults cut removed.
    pub(super) peers: &'a [Vec<RobotId>],
    /// A run without blocks checkpoints at every multiple of this (the block period), in ms.
    pub(super) checkpoint_period_ms: u64,
}

impl Protocol {
    /// The agents of `config.learn.aggregation` (which no reconfiguration changes).
    pub(super) fn new(config: &Config, seed: u64) -> Protocol {
        match config.learn.aggregation {
            Aggregation::Chain => {
                let agents = LedgerAgents::new(config, seed);
                let mut network = Network::new(config, seed);
                network.set_withhold(agents.withhold_policy());
                Protocol::Chain(Box::new(Chain { network, agents }))
            }
            Aggregation::Gossip => Protocol::Gossip(Box::new(Gossiper::new(config, seed))),
            Aggregation::Central | Aggregation::Matched => Protocol::Central,
        }
    }

    /// Emits the radio's events of the tick (ledger or stigmergy) and, without blocks, the
    /// periodic checkpoint.
    pub(super) fn tick(&mut self, rec: &mut Recorder, faults: &FaultSchedule, tick: &RadioTick) {
        match self {
            Protocol::Chain(chain) => chain.tick(rec, faults, tick),
            Protocol::Gossip(gossiper) => {
                while let Some((at, event)) =
                    gossiper.next_event(&rec.state.aggregation.stigmergy, tick.now, tick.peers)
                {
                    rec.emit(at, Event::Aggregation(event));
                }
            }
            // The ideal server is not on the radio: uploads and downloads are instant.
            Protocol::Central => {}
        }
        if !matches!(self, Protocol::Chain(_))
            && tick.now.0.is_multiple_of(tick.checkpoint_period_ms)
        {
            // No blocks: a checkpoint every block period pins the state for replay, inspect
            // and bisect by time.
            rec.checkpoint(tick.now, CheckpointCause::Periodic);
        }
    }

    /// `robot`'s learning phase begins: a baseline robot merges its replica (gossip) or
    /// downloads the server's model (central), Byzantine or not, and that is an event. A
    /// chain robot reads its own node's head, which is no event.
    pub(super) fn phase_begins(&self, rec: &mut Recorder, now: SimTime, robot: RobotId) {
        if !matches!(self, Protocol::Chain(_)) {
            rec.emit(now, Event::Aggregation(AggregationEvent::Merge { robot }));
        }
    }

    /// Whether `robot`'s balance on its own chain is below `stake_units` (0 when the rule does
    /// not stake). The baselines have no tokens.
    pub(super) fn lacks_stake(&self, state: &State, robot: RobotId, stake_units: u64) -> bool {
        match self {
            Protocol::Chain(_) => {
                state.ledger.head_state(robot).balances[robot as usize] < stake_units
            }
            Protocol::Gossip(_) | Protocol::Central => false,
        }
    }

    /// Whether `robot`'s model already waits in the open round: on its own chain, or at the
    /// server. A stigmergy write never waits (each phase overwrites the robot's key).
    pub(super) fn submitted(&self, state: &State, robot: RobotId) -> bool {
        match self {
            Protocol::Chain(_) => state.ledger.head_state(robot).has_submitted(robot),
            Protocol::Gossip(_) => false,
            Protocol::Central => {
                state.aggregation.kind() == Aggregation::Central
                    && state.aggregation.server.has_pending(robot)
            }
        }
    }

    /// What `robot` starts from now: the shared model at its own chain's head, its model after
    /// its last merge (`gossip`), or the server's model (`central`).
    pub(super) fn current(&self, state: &State, robot: RobotId) -> Start {
        match self {
            Protocol::Chain(_) => {
                let head = state.ledger.head_state(robot);
                Start {
                    weights: head.weights.clone(),
                    digest: head.weights_digest,
                    round: head.round,
                }
            }
            Protocol::Gossip(_) | Protocol::Central => {
                Start::from(state.aggregation.current(robot))
            }
        }
    }

    /// What `robot` would start from if its phase began now (for speculative training): as
    /// [`Protocol::current`], except that a `gossip` robot would merge its replica as it is now.
    pub(super) fn preview(&self, state: &State, robot: RobotId) -> Start {
        match self {
            Protocol::Chain(_) => self.current(state, robot),
            Protocol::Gossip(_) | Protocol::Central => {
                Start::from(state.aggregation.preview(robot))
            }
        }
    }

    /// The contract state a Byzantine `robot`'s attack reads: its own chain's head or, without
    /// a chain, the same kind of view built from what the robot holds (its stigmergy replica,
    /// or the server: `AggregationState::attacker_view`).
    pub(super) fn chain_view<'s>(
        &self,
        state: &'s State,
        robot: RobotId,
    ) -> Cow<'s, ContractState> {
        match self {
            Protocol::Chain(_) => Cow::Borrowed(state.ledger.head_state(robot)),
            Protocol::Gossip(_) | Protocol::Central => Cow::Owned(
                state
                    .aggregation
                    .attacker_view(robot, state.ledger.current_params()),
            ),
        }
    }

    /// The submission of `weights` claiming `samples` by `robot` and its identity in the
    /// learning report: a transaction signed by its own node (staking `stake_units`; under the
    /// buffered protocol naming the base its node's head shows), or a baseline's write or
    /// upload. Under `contract.gas_limit = "estimate"` the transaction is made again with its
    /// gas when the robot sends it (`gas_estimate.rs`).
    pub(super) fn submission(
        &self,
        state: &State,
        robot: RobotId,
        stake_units: u64,
        weights: Vec<i64>,
        samples: u64,
    ) -> (Digest, Submission) {
        let weights: Arc<[i64]> = Arc::from(weights);
        match self {
            Protocol::Chain(_) => {
                let head = state.ledger.head_state(robot);
                let call = if head.buffered.is_some() {
                    // The buffered protocol: the base is what the robot trained from, its
                    // node's head when its phase began (the submission is made in that tick).
                    Call::SubmitUpdate {
                        weights,
                        samples,
                        base_round: head.round,
                        base_digest: head.weights_digest,
                    }
                } else {
                    Call::SubmitModel { weights, samples }
                };
                let tx = state.ledger.make_tx(robot, stake_units, call);
                (tx.hash_and_size().0, Submission::Tx(tx))
            }
            Protocol::Gossip(_) | Protocol::Central => {
                let a = &state.aggregation;
                (
                    a.next_hash(robot, samples, weights.clone()),
                    Submission::Baseline(a.submission(robot, samples, weights)),
                )
            }
        }
    }
}

impl Chain {
    /// The ledger's part of the tick: restarts of crashed nodes, the sealings, gossip and
    /// deliveries due, the Byzantine nodes' injections.
    fn tick(&mut self, rec: &mut Recorder, faults: &FaultSchedule, tick: &RadioTick) {
        let (time, now, peers) = (tick.time, tick.now, tick.peers);
        for (restart_ms, robot) in faults.restart_times(time.0, now.0) {
            self.until(rec, SimTime(restart_ms - 1), peers);
            self.network.on_restart(robot);
            rec.emit(
                SimTime(restart_ms),
                Event::Ledger(LedgerEvent::Restart { node: robot }),
            );
        }
        self.until(rec, now, peers);
        let injections = self
            .agents
            .on_tick(&rec.state.ledger, now, peers, &|r| faults.is_down(r, now.0));
        for event in injections {
            rec.emit(now, Event::Ledger(event));
        }
    }

    /// Applies the ledger events due until `until`: a checkpoint after each sealing, and the
    /// sealer's misbehaviour right after it, if it is Byzantine on the ledger.
    fn until(&mut self, rec: &mut Recorder, until: SimTime, peers: &[Vec<RobotId>]) {
        while let Some((at, event)) = self.network.next_event(&rec.state.ledger, until, peers) {
            let sealed = match &event {
                LedgerEvent::Seal { node, .. } => Some(*node),
                _ => None,
            };
            rec.emit(at, Event::Ledger(event));
            if let Some(node) = sealed {
                let (head, height) = rec.state.ledger.head(node);
                rec.checkpoint(at, CheckpointCause::Block { node, height });
                rec.switch(Part::Ledger);
                let injections = self
                    .agents
                    .after_seal(&rec.state.ledger, node, head, at, peers);
                for event in injections {
                    rec.emit(at, Event::Ledger(event));
                }
            }
        }
    }
}

//! The chaos campaign (VOPR-style): each seed draws a configuration, Byzantine behaviours and
//! a fault schedule ([`draw`]), runs it, and checks invariants at every block ([`check`]).
//!
//! The invariants, checked on the reduced state after every sealed block and at the end:
//! - *conservation*: at every honest node's head, balances plus the contract's holdings equal
//!   the supply, no balance exceeds the supply (a wrapped negative would), and the contract
//!   holds at least the open round's stakes;
//! - *validity*: every block on an honest node's canonical chain passes
//!   [`crate::ledger::Ledger::check_block`], a from-scratch check of signatures, Clique rules,
//!   limits, nonces and a fresh execution of its transactions (each block once);
//! - *agreement*: from [`SETTLE_MS`] after the last fault heals, every honest node that is up
//!   agrees with the heaviest honest chain on everything but at most its last
//!   [`PREFIX_BOUND_BLOCKS`] blocks (a lagging node is behind, not in disagreement);
//! - *liveness*: within [`LIVENESS_MS`] after the last fault heals, the round of some honest
//!   node's head advances (an aggregation) or a deadline closes a round; not checked when the
//!   run ends before that time. Two things the contract's own rules decide, not the faults,
//!   shape that window ([`liveness_window_ms`], [`quorum_out_of_reach`]): with a deadline, a
//!   round that cannot close ends at its deadline, which may lie up to the deadline after the
//!   heal; without one, a round whose quorum no robot can still complete (too few robots
//!   left that hold a stake, have not yet submitted and hold enough data to train on) never
//!   closes, in a run without any fault as well (the paper's contract), so liveness is owed
//!   only while the quorum is within reach, and a run where it was not is counted as
//!   *stalled* (`liveness_stalled`). Data run out in small sparse swarms: 5 robots in a 5 m
//!   arena meet rarely, and with windows saved only when confirmed (`data.window_rule`) and
//!   samples expiring, every honest robot that still holds a stake may hold too few;
//! - *punishment*: on every honest node's canonical chain, no block is sealed by a sealer
//!   that the chain's evidence removed (the removed sets recomputed here from the evidence
//!   the headers carry, and compared with the ledger's), and no honest sealer is ever
//!   removed; and once an honest node holds evidence of an equivocation on a parent of the
//!   heaviest honest chain, that chain removes the sealer within [`PUNISH_MS`] of the time in
//!   which the evidence could reach it: checkpoints after the last heal at which a holder and
//!   the chain's node are connected through honest robots that are up ([`EvidenceClock`]). A
//!   holder that mobility keeps out of radio reach of the heaviest chain cannot hand it the
//!   evidence, whatever the ledger does.
//!
//! The drawn configurations are small and fast (5 to 15 robots, small models, short training
//! periods) so a campaign of hundreds of seeds fits in minutes; Byzantine robots stay below a
//! third of the swarm (Clique, like every BFT-style protocol, needs an honest majority).

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::byzantine;
use crate::config::{ByzantineKind, Config, LearnConfig, LedgerBehaviour, Preset};
use crate::contract::{ContractParams, ContractState};
use crate::event::{CheckpointCause, Record};
use crate::faults::{FaultSchedule, FaultsConfig};
use crate::ledger::{BlockHash, Ledger};
use crate::rng::{self, Purpose};
use crate::sim::Sim;
use crate::state::SimError;
use crate::types::RobotId;
use crate::world::World;

/// Blocks at the end of an honest chain that may disagree with the heaviest honest chain once
/// the faults have healed and settled.
pub const PREFIX_BOUND_BLOCKS: u64 = 12;

/// Time after the last heal before agreement is required, ms.
pub const SETTLE_MS: u64 = 60_000;

/// Time after the last heal within which a round must close, ms.
pub const LIVENESS_MS: u64 = 240_000;

/// Time after a round's deadline within which a block must have fired it on the heaviest
/// honest chain, ms: the network needs [`SETTLE_MS`] after a heal to agree.
pub const DEADLINE_SLACK_MS: u64 = SETTLE_MS;

/// The time after the last heal within which a round must close or time out under a round
/// deadline of `round_timeout_ms` (0: none): [`LIVENESS_MS`], or with a deadline, at least
/// that deadline plus [`DEADLINE_SLACK_MS`] (the round open at the heal opened at or before
/// it, so its deadline lies at most `round_timeout_ms` after the heal, and a stuck round is
/// only guaranteed to end there).
pub fn liveness_window_ms(round_timeout_ms: u64) -> u64 {
    if round_timeout_ms == 0 {
        LIVENESS_MS
    } else {
        LIVENESS_MS.max(round_timeout_ms.saturating_add(DEADLINE_SLACK_MS))
    }
}

/// Whether the open round of `state` cannot reach its quorum under `params` now: no
/// deadline, and the accepted submissions plus the robots that may still submit are fewer
/// than the quorum. A robot may submit when it has not submitted in this round, holds at
/// least the stake, and `able[robot]` (missing: true): an honest robot must hold enough data
/// to train on (else it skips its round, `not_enough_data`) and be within radio reach of the
/// chain (a robot that mobility keeps alone cannot get its submission sealed). Outliers have
/// submitted and cannot again; Byzantine robots forge without data and may be anywhere, so the
/// caller passes `true` for them, and the answer errs towards checking liveness. Balances
/// move only by payouts, deadlines and transfers, data sets by meetings and expiry, links by
/// motion, so the stall ends by a transfer or a meeting, which this sees at the next
/// checkpoint.
pub fn quorum_out_of_reach(params: &ContractParams, state: &ContractState, able: &[bool]) -> bool {
    if params.round_timeout_ms != 0 {
        return false;
    }
    let may_submit = state
        .balances
        .iter()
        .enumerate()
        .filter(|&(r, &b)| {
            (!params.security || b >= params.stake_units)
                && !state.has_submitted(r as RobotId)
                && able.get(r).copied().unwrap_or(true)
        })
        .count() as u64;
    u64::from(state.accepted_count()) + may_submit < u64::from(params.quorum)
}

/// Time during which the evidence of an equivocation could reach the heaviest honest chain
/// (after the last heal) within which that chain removes the sealer, ms: enough for a
/// holder's turn to seal to come round in a swarm of 15 at a 10 s period, with room for its
/// block to be orphaned once.
pub const PUNISH_MS: u64 = 240_000;

/// How long the evidence against one (sealer, parent) could reach the heaviest honest chain.
///
/// Advanced at every checkpoint: the span since the previous checkpoint (from the last heal at
/// the earliest) counts when, at this checkpoint, an honest holder of the evidence is connected
/// to the chain's node through honest robots that are up. Evidence travels only over the
/// radio's links, so the time a holder spends out of reach of that chain (mobility splits a
/// small swarm for minutes) owes the chain nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EvidenceClock {
    /// When an honest node was first seen holding the evidence, ms.
    pub held_since_ms: u64,
    /// Time within reach so far, ms.
    pub reachable_ms: u64,
    /// The checkpoint the clock was last advanced at, ms.
    last_ms: u64,
}

impl EvidenceClock {
    /// A clock for evidence first seen at the checkpoint at `now_ms`.
    pub fn new(now_ms: u64) -> EvidenceClock {
        EvidenceClock {
            held_since_ms: now_ms,
            reachable_ms: 0,
            last_ms: now_ms,
        }
    }

    /// Advances to the checkpoint at `now_ms`; the span since the last one counts, from
    /// `heal_ms` at the earliest, if the evidence was `reachable` at this checkpoint.
    pub fn advance(&mut self, now_ms: u64, heal_ms: u64, reachable: bool) {
        let from = self.last_ms.max(heal_ms);
        if reachable && now_ms > from {
            self.reachable_ms += now_ms - from;
        }
        self.last_ms = self.last_ms.max(now_ms);
    }

    /// Whether the chain has had its time to remove the sealer.
    pub fn overdue(&self) -> bool {
        self.reachable_ms > PUNISH_MS
    }
}

/// The configuration seed `seed` of a campaign with runs of `duration_s` draws.
pub fn draw(seed: u64, duration_s: f64) -> Config {
    let mut rng = rng::stream(seed, Purpose::Faults, 0);
    let mut c = Preset::Smoke.config();
    c.run.duration_s = duration_s;
    let robots = 5 + rng.below(11) as u32;
    c.world.robots = robots;
    c.learn.lstm_units = 4 + rng.below(5) as u32;
    c.learn.epochs = 1 + rng.below(2) as u32;
    c.learn.training_period_s = 20.0 + rng.below(41) as f64;
    c.contract.security = rng.chance(0.8);
    c.contract.quorum_fraction = 0.3 + 0.3 * rng.uniform();
    // The paper's two penalised ranks need a quorum of at least three.
    c.contract.penalised_ranks = c.contract.penalised_ranks.min(c.quorum() - 1);
    c.contract.round_timeout_s = if rng.chance(0.5) {
        0.0
    } else {
        60.0 + rng.below(241) as f64
    };
    c.ledger.packet_loss = if rng.chance(0.5) {
        0.0
    } else {
        0.2 * rng.uniform()
    };
    c.ledger.bandwidth_bytes_per_s = if rng.chance(0.5) {
        0
    } else {
        20_000 + rng.below(200_000)
    };
    let count = rng.below(u64::from((robots - 1) / 3) + 1) as u32;
    c.byzantine.count = count;
    if count > 0 {
        c.byzantine.kind = [
            ByzantineKind::None,
            ByzantineKind::Faulty,
            ByzantineKind::Malicious,
            ByzantineKind::Smart,
        ][rng.below(4) as usize];
        c.byzantine.ledger = CHAOS_LEDGER[rng.below(CHAOS_LEDGER.len() as u64) as usize];
        if c.byzantine.kind == ByzantineKind::None && c.byzantine.ledger == LedgerBehaviour::Honest
        {
            c.byzantine.ledger =
                CHAOS_LEDGER_MISBEHAVING[rng.below(CHAOS_LEDGER_MISBEHAVING.len() as u64) as usize];
        }
    }
    c.faults = FaultsConfig::draw(
        &mut rng::stream(seed, Purpose::Faults, 1),
        robots,
        duration_s,
    );
    c
}

/// One broken invariant.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Violation {
    /// Which invariant.
    pub invariant: String,
    /// Simulated time, ms.
    pub at_ms: u64,
    /// What was seen.
    pub detail: String,
}

/// What a checked run found.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Outcome {
    /// Blocks checked from scratch.
    pub blocks_checked: u64,
    /// Checkpoints at which the invariants were evaluated.
    pub checks: u64,
    /// Whether the liveness window fitted in the run.
    pub liveness_checked: bool,
    /// Whether liveness was found owed nothing at some checkpoint after the last heal: the
    /// open round's quorum out of reach under a contract without a deadline, for want of
    /// stakes or of data ([`quorum_out_of_reach`]).
    #[serde(default)]
    pub liveness_stalled: bool,
    /// The first broken invariant, if any (the run stops there).
    pub violation: Option<Violation>,
    /// Highest canonical head at the end.
    pub height: u64,
    /// Deepest reorganisation.
    pub deepest_reorg: u64,
    /// Equivocation sites detected.
    pub equivocations: u64,
    /// Sealers removed from the signer set (for equivocating) on the heaviest honest chain
    /// at the end.
    #[serde(default)]
    pub removed_sealers: u64,
    /// Rounds closed by aggregation on the heaviest honest chain.
    pub rounds: u64,
}

/// Runs `config` with `seed` and checks the invariants at every block; stops at the first
/// violation.
pub fn check(config: Config, seed: u64) -> Result<Outcome, SimError> {
    let robots = config.world.robots;
    let byzantine = byzantine::byzantine_robots(&config, seed);
    let end_ms = config.ticks() * (config.run.tick_s * 1000.0).round() as u64;
    let heal_ms = config.faults.last_heal_ms();
    let window_ms = liveness_window_ms((config.contract.round_timeout_s * 1000.0).round() as u64);
    let mut watch = Watch {
        honest: (0..robots).filter(|&r| !byzantine[r as usize]).collect(),
        faults: FaultSchedule::new(&config.faults, robots),
        heal_ms,
        liveness_checked: heal_ms + window_ms <= end_ms,
        liveness_from: heal_ms,
        liveness_stalled: false,
        checked: BTreeSet::new(),
        blocks_checked: 0,
        round_at_heal: None,
        live: false,
        removed_on: BTreeMap::new(),
        evidence: BTreeMap::new(),
        component: Vec::new(),
        can_train: Vec::new(),
    };
    let mut outcome = Outcome {
        liveness_checked: watch.liveness_checked,
        ..Outcome::default()
    };
    let mut sim = Sim::new(config, seed)?;
    while let Some(record) = sim.next() {
        let Record::Checkpoint(cp) = record else {
            continue;
        };
        if !matches!(
            cp.cause,
            CheckpointCause::Block { .. } | CheckpointCause::End
        ) {
            continue;
        }
        let now = cp.time.0;
        outcome.checks += 1;
        watch.component = honest_components(&sim.state().world, &watch, now);
        watch.can_train = can_train(&sim.state().world, &sim.config().learn, &byzantine);
        if let Err((invariant, detail)) = watch.at(&sim.state().ledger, now) {
            outcome.violation = Some(Violation {
                invariant: invariant.to_string(),
                at_ms: now,
                detail,
            });
            break;
        }
    }
    let ledger = &sim.state().ledger;
    outcome.blocks_checked = watch.blocks_checked;
    outcome.liveness_stalled = watch.liveness_stalled;
    let stats = ledger.stats();
    outcome.height = stats.canonical_height;
    outcome.deepest_reorg = stats.deepest_reorg;
    outcome.equivocations = stats.equivocations.iter().map(|e| e.sites).sum();
    outcome.removed_sealers = reference_node(&watch.honest, ledger).map_or(0, |r| {
        ledger.removed_signers(&ledger.head(r).0).len() as u64
    });
    outcome.rounds = watch
        .honest
        .iter()
        .map(|&r| ledger.head_state(r).round)
        .max()
        .unwrap_or(0);
    if outcome.violation.is_none() {
        outcome.violation = final_chains_valid(ledger, &watch.honest)
            .err()
            .map(|detail| Violation {
                invariant: "validity".to_string(),
                at_ms: end_ms,
                detail,
            });
    }
    Ok(outcome)
}

/// A broken invariant, before its time is attached: (invariant, what was seen).
type Broken = (&'static str, String);

/// An invariant of one honest node's head.
type NodeCheck = fn(&mut Watch, &Ledger, RobotId) -> Result<(), Broken>;

/// An invariant of the whole swarm at a checkpoint (time in ms).
type SwarmCheck = fn(&mut Watch, &Ledger, u64) -> Result<(), Broken>;

/// The ledger behaviours a campaign draws from, by the draw's value (a named list, not a slice
/// of [`LedgerBehaviour::ALL`]: a new behaviour in the registry must not move the behaviour a
/// seed draws, or every recorded campaign would change meaning).
const CHAOS_LEDGER: [LedgerBehaviour; 7] = [
    LedgerBehaviour::Honest,
    LedgerBehaviour::Equivocate,
    LedgerBehaviour::Withhold,
    LedgerBehaviour::Flood,
    LedgerBehaviour::Replay,
    LedgerBehaviour::SpamInvalid,
    LedgerBehaviour::FutureTimestamp,
];

/// The misbehaving ones, drawn again when the first draw made a Byzantine robot of no kind
/// and an honest ledger ([`CHAOS_LEDGER`] without `honest`, in its order).
const CHAOS_LEDGER_MISBEHAVING: [LedgerBehaviour; 6] = [
    LedgerBehaviour::Equivocate,
    LedgerBehaviour::Withhold,
    LedgerBehaviour::Flood,
    LedgerBehaviour::Replay,
    LedgerBehaviour::SpamInvalid,
    LedgerBehaviour::FutureTimestamp,
];

/// The invariants of each honest node, in the order they are checked: all of them for one
/// node, then the next node; the first broken one is reported.
const NODE_CHECKS: [NodeCheck; 5] = [
    supply_conserved,
    no_negative_balance,
    stakes_held,
    chain_valid,
    removed_stop_sealing,
];

/// The invariants of the swarm, checked after every node's.
const SWARM_CHECKS: [SwarmCheck; 3] = [agreement, liveness, equivocators_removed];

/// What the checks know of the run and remember between checkpoints.
struct Watch {
    /// The honest robots, in id order.
    honest: Vec<RobotId>,
    /// When each robot is down.
    faults: FaultSchedule,
    /// When the last fault heals, ms.
    heal_ms: u64,
    /// Whether the liveness window fits in the run.
    liveness_checked: bool,
    /// Since when liveness is owed, ms: the last heal, or the last checkpoint at which the
    /// open round's quorum was out of reach, if later.
    liveness_from: u64,
    /// Whether the quorum was ever out of reach after the last heal.
    liveness_stalled: bool,
    /// Blocks already checked from scratch (each is checked once).
    checked: BTreeSet<BlockHash>,
    /// How many that is.
    blocks_checked: u64,
    /// Rounds closed or timed out at the first checkpoint after the last heal.
    round_at_heal: Option<u64>,
    /// Whether a round closed or timed out since then.
    live: bool,
    /// The removed signers after each block of an honest canonical chain seen so far, as
    /// recomputed here from the evidence in the headers (genesis: none).
    removed_on: BTreeMap<BlockHash, Arc<BTreeSet<RobotId>>>,
    /// The evidence against each (sealer, parent) an honest node was seen holding, and how
    /// long it could reach the heaviest honest chain.
    evidence: BTreeMap<(RobotId, BlockHash), EvidenceClock>,
    /// The connected component of each robot at this checkpoint, over the radio's links
    /// between honest robots that are up (`None`: Byzantine or down).
    component: Vec<Option<u32>>,
    /// Whether each robot could submit as far as data go at this checkpoint: Byzantine
    /// robots always (they forge), honest ones when their data set is large enough to train.
    /// (Radio reach is judged in [`liveness`], from `component`.)
    can_train: Vec<bool>,
}

impl Watch {
    /// Checks every invariant at the checkpoint at `now_ms`.
    fn at(&mut self, ledger: &Ledger, now_ms: u64) -> Result<(), Broken> {
        for i in 0..self.honest.len() {
            let r = self.honest[i];
            for check in NODE_CHECKS {
                check(self, ledger, r)?;
            }
        }
        for check in SWARM_CHECKS {
            check(self, ledger, now_ms)?;
        }
        Ok(())
    }
}

/// *Conservation*: balances plus holdings at the node's head equal the supply.
fn supply_conserved(_: &mut Watch, ledger: &Ledger, r: RobotId) -> Result<(), Broken> {
    let supply = ledger.params().total_units();
    let state = ledger.head_state(r);
    if state.total_units() != supply {
        return Err((
            "conservation",
            format!("node {r}: {} units, supply {supply}", state.total_units()),
        ));
    }
    Ok(())
}

/// No balance exceeds the supply (a wrapped negative one would).
fn no_negative_balance(_: &mut Watch, ledger: &Ledger, r: RobotId) -> Result<(), Broken> {
    let supply = ledger.params().total_units();
    let state = ledger.head_state(r);
    if let Some((a, b)) = state
        .balances
        .iter()
        .enumerate()
        .find(|(_, b)| u128::from(**b) > supply)
    {
        return Err((
            "no negative balance",
            format!("node {r}: account {a} holds {b}"),
        ));
    }
    Ok(())
}

/// *Conservation*: the contract holds at least the open round's stakes.
fn stakes_held(_: &mut Watch, ledger: &Ledger, r: RobotId) -> Result<(), Broken> {
    let state = ledger.head_state(r);
    let stakes: u64 = state.submissions.iter().map(|s| s.stake_units).sum();
    if state.holdings_units < stakes {
        return Err((
            "conservation",
            format!(
                "node {r}: holdings {} < open stakes {stakes}",
                state.holdings_units
            ),
        ));
    }
    Ok(())
}

/// *Validity*: every block of the node's canonical chain not checked before passes the
/// from-scratch check (walking back from the head, down to the first block already checked).
fn chain_valid(watch: &mut Watch, ledger: &Ledger, r: RobotId) -> Result<(), Broken> {
    for hash in ledger.canonical_chain(r).iter().rev() {
        if !watch.checked.insert(*hash) {
            break;
        }
        watch.blocks_checked += 1;
        if let Err(e) = ledger.check_block(hash) {
            return Err((
                "validity",
                format!("node {r} accepted an invalid block: {e}"),
            ));
        }
    }
    Ok(())
}

/// *Punishment*: along the node's canonical chain (the blocks not seen before), the removed
/// signers recomputed from the evidence the headers carry: no block is sealed by a signer its
/// parent's chain removed, the ledger's removed set after each block is the same, and no
/// honest robot is ever removed.
fn removed_stop_sealing(watch: &mut Watch, ledger: &Ledger, r: RobotId) -> Result<(), Broken> {
    let chain = ledger.canonical_chain(r);
    let known = chain.iter().rposition(|h| watch.removed_on.contains_key(h));
    let start = match known {
        Some(i) => i + 1,
        None => {
            watch
                .removed_on
                .insert(ledger.genesis(), Arc::new(BTreeSet::new()));
            1
        }
    };
    for hash in &chain[start..] {
        let Some(entry) = ledger.block(hash) else {
            return Err(("punishment", format!("node {r}: block {hash:?} not stored")));
        };
        let h = &entry.block.header;
        let before = watch
            .removed_on
            .get(&h.parent)
            .cloned()
            .expect("the chain is walked from a block already seen");
        if before.contains(&h.signer) {
            return Err((
                "punishment",
                format!(
                    "node {r}: block {} at height {} is sealed by {}, which its chain removed \
                     for equivocating",
                    hash.short(),
                    h.height,
                    h.signer
                ),
            ));
        }
        let after = if h.evidence.is_empty() {
            before
        } else {
            let mut set = (*before).clone();
            set.extend(h.evidence.iter().map(|e| e.signer));
            Arc::new(set)
        };
        if let Some(honest) = after.iter().find(|s| watch.honest.binary_search(s).is_ok()) {
            return Err((
                "punishment",
                format!(
                    "node {r}: block {} at height {} removes honest sealer {honest}",
                    hash.short(),
                    h.height
                ),
            ));
        }
        let cached = ledger.removed_signers(hash);
        if !cached.iter().eq(after.iter()) {
            return Err((
                "punishment",
                format!(
                    "node {r}: after block {} the ledger removed {cached:?}, the evidence {:?}",
                    hash.short(),
                    after
                ),
            ));
        }
        watch.removed_on.insert(*hash, after);
    }
    Ok(())
}

/// The heaviest honest node's id (ties to the lowest id) among `nodes`.
fn reference_node(nodes: &[RobotId], ledger: &Ledger) -> Option<RobotId> {
    nodes
        .iter()
        .copied()
        .max_by_key(|&r| (ledger.head_total_difficulty(r), std::cmp::Reverse(r)))
}

/// Whether each robot holds enough data to submit at this checkpoint (see [`Watch::can_train`]):
/// the driver's own test, a training split of at least `learn.min_train_samples` (and 1).
fn can_train(world: &World, learn: &LearnConfig, byzantine: &[bool]) -> Vec<bool> {
    let min_train = learn.min_train_samples.max(1) as usize;
    byzantine
        .iter()
        .enumerate()
        .map(|(r, &b)| {
            b || crate::learn::split_point(world.dataset_len(r as RobotId), learn.train_fraction)
                >= min_train
        })
        .collect()
}

/// The connected components of the radio's links (the world's peer sets) between the honest
/// robots that are up at `now_ms`, numbered by their lowest robot; `None` for the others.
fn honest_components(world: &World, watch: &Watch, now_ms: u64) -> Vec<Option<u32>> {
    let robots = world.poses().len();
    let mut eligible = vec![false; robots];
    for &r in &watch.honest {
        eligible[r as usize] = !watch.faults.is_down(r, now_ms);
    }
    let mut component = vec![None; robots];
    let mut stack = Vec::new();
    for start in 0..robots {
        if !eligible[start] || component[start].is_some() {
            continue;
        }
        component[start] = Some(start as u32);
        stack.push(start as RobotId);
        while let Some(r) = stack.pop() {
            for &p in world.peers(r) {
                if eligible[p as usize] && component[p as usize].is_none() {
                    component[p as usize] = Some(start as u32);
                    stack.push(p);
                }
            }
        }
    }
    component
}

/// *Punishment*: an honest node's evidence of an equivocation on a parent of the heaviest
/// honest chain (of the nodes up) leads that chain to remove the sealer within [`PUNISH_MS`]
/// of the time in which the evidence could reach it ([`EvidenceClock`]).
fn equivocators_removed(watch: &mut Watch, ledger: &Ledger, now_ms: u64) -> Result<(), Broken> {
    let up: Vec<RobotId> = watch
        .honest
        .iter()
        .copied()
        .filter(|&r| !watch.faults.is_down(r, now_ms))
        .collect();
    let reference = reference_node(&up, ledger);
    let reference_component = reference.and_then(|r| watch.component[r as usize]);
    let mut reachable = BTreeSet::new();
    for &r in &watch.honest {
        let in_reach =
            reference_component.is_some() && watch.component[r as usize] == reference_component;
        for key in ledger.node(r).evidence().keys() {
            watch
                .evidence
                .entry(*key)
                .or_insert_with(|| EvidenceClock::new(now_ms));
            if in_reach {
                reachable.insert(*key);
            }
        }
    }
    for (key, clock) in watch.evidence.iter_mut() {
        clock.advance(now_ms, watch.heal_ms, reachable.contains(key));
    }
    let Some(reference) = reference else {
        return Ok(());
    };
    let chain = ledger.canonical_chain(reference);
    let head = ledger.head(reference).0;
    for (&(sealer, parent), clock) in &watch.evidence {
        if !clock.overdue() || ledger.removed_at(&head, sealer) {
            continue;
        }
        let on_chain = ledger
            .block(&parent)
            .is_some_and(|e| chain.get(e.block.header.height as usize) == Some(&parent));
        if on_chain {
            return Err((
                "punishment",
                format!(
                    "sealer {sealer} equivocated on block {} (evidence held since {} s, within \
                     radio reach of node {reference} for {} s since) and is still a signer on \
                     node {reference}'s chain",
                    parent.short(),
                    clock.held_since_ms / 1000,
                    clock.reachable_ms / 1000
                ),
            ));
        }
    }
    Ok(())
}

/// *Agreement*: once the faults have healed and settled, every honest node that is up agrees
/// with the heaviest of their chains but for at most its last [`PREFIX_BOUND_BLOCKS`] blocks.
fn agreement(watch: &mut Watch, ledger: &Ledger, now_ms: u64) -> Result<(), Broken> {
    let up: Vec<RobotId> = watch
        .honest
        .iter()
        .copied()
        .filter(|&r| !watch.faults.is_down(r, now_ms))
        .collect();
    if now_ms < watch.heal_ms + SETTLE_MS || up.is_empty() {
        return Ok(());
    }
    let reference = *up
        .iter()
        .max_by_key(|&&r| {
            let (head, _) = ledger.head(r);
            (
                ledger.block(&head).map_or(0, |e| e.total_difficulty),
                std::cmp::Reverse(r),
            )
        })
        .expect("not empty");
    let main = ledger.canonical_chain(reference);
    for &r in &up {
        let chain = ledger.canonical_chain(r);
        let common = chain
            .iter()
            .zip(main.iter())
            .take_while(|(a, b)| a == b)
            .count() as u64;
        let own = chain.len() as u64 - common;
        if own > PREFIX_BOUND_BLOCKS {
            return Err((
                "agreement",
                format!(
                    "node {r}'s last {own} blocks disagree with node {reference}'s chain \
                     (bound {PREFIX_BOUND_BLOCKS})"
                ),
            ));
        }
    }
    Ok(())
}

/// *Liveness*: within [`liveness_window_ms`] after the last heal (or after the open round's
/// quorum last was out of reach, if later), some honest head's round count (closed plus timed
/// out) grows past the one seen at the first checkpoint after the heal.
fn liveness(watch: &mut Watch, ledger: &Ledger, now_ms: u64) -> Result<(), Broken> {
    if now_ms < watch.heal_ms {
        return Ok(());
    }
    let round = watch
        .honest
        .iter()
        .map(|&r| {
            let s = ledger.head_state(r);
            (s.round, s.rounds_timed_out)
        })
        .max()
        .unwrap_or((0, 0));
    match watch.round_at_heal {
        None => watch.round_at_heal = Some(round.0 + round.1),
        Some(r0) => watch.live |= round.0 + round.1 > r0,
    }
    if watch.live {
        return Ok(());
    }
    let params = ledger.params_at(now_ms);
    let Some(reference) = reference_node(&watch.honest, ledger) else {
        return Ok(());
    };
    let state = ledger.head_state(reference);
    // Honest robots count when they can train and share the reference node's radio component
    // (all of them when that node is down and so in none).
    let chain = watch.component.get(reference as usize).copied().flatten();
    let able: Vec<bool> = (0..watch.can_train.len())
        .map(|r| {
            let honest = watch.honest.binary_search(&(r as RobotId)).is_ok();
            watch.can_train[r] && (!honest || chain.is_none() || watch.component[r] == chain)
        })
        .collect();
    if quorum_out_of_reach(params, state, &able) {
        watch.liveness_from = now_ms;
        watch.liveness_stalled = true;
        return Ok(());
    }
    let window = liveness_window_ms(params.round_timeout_ms);
    if watch.liveness_checked && now_ms > watch.liveness_from + window {
        let since = if watch.liveness_from == watch.heal_ms {
            format!("the last heal at {} s", watch.heal_ms / 1000)
        } else {
            format!(
                "the open round's quorum came back within reach at {} s",
                watch.liveness_from / 1000
            )
        };
        return Err((
            "liveness",
            format!(
                "no round closed within {} s after {since} (node {reference}: round {} open, \
                 {} accepted of a quorum of {})",
                window / 1000,
                state.round + 1,
                state.accepted_count(),
                params.quorum
            ),
        ));
    }
    Ok(())
}

/// *Validity* at the end: every honest node's whole chain passes the full check.
fn final_chains_valid(ledger: &Ledger, honest: &[RobotId]) -> Result<(), String> {
    for &r in honest {
        if let Err(e) = ledger.check_chain(r) {
            return Err(format!("node {r}'s chain fails the full check: {e}"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;

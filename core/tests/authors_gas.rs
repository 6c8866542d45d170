//! `contract.gas_limit = "estimate"` in a whole run: the records are a function of the seed (on
//! 1 and 2 threads), every robot transaction carries its estimate and limit, the reducers
//! re-derive every checkpoint from the events, and some submissions run out of gas. The
//! estimate on a node's pending block sees the transactions of its mempool that block would
//! take (after the miner's recommit), and a call that state refuses is not sent.
#![cfg(feature = "evm")]

use std::sync::Arc;

use swarmfl_core::config::{ContractEngine, GasEstimateState, GasLimitRule, WEB3_GAS_MARGIN};
use swarmfl_core::contract::gas_limit::{self, EstimateFailed};
use swarmfl_core::contract::{Call, Outcome};
use swarmfl_core::event::{Event, Record};
use swarmfl_core::ledger::{ItemRef, LedgerEvent};
use swarmfl_core::metrics::{LearnAction, SkipReason};
use swarmfl_core::state::State;
use swarmfl_core::types::SimTime;

/// A smoke run under the evm engine with the authors' gas limits, on `threads` pool threads.
fn authors_gas_run(threads: usize) -> Vec<swarmfl_core::event::Record> {
    let mut config = swarmfl_core::config::Preset::Smoke.config();
    config.contract.engine = ContractEngine::Evm;
    config.contract.gas_limit = GasLimitRule::Estimate;
    config.contract.gas_estimate_state = GasEstimateState::Head;
    config.validate().expect("a valid configuration");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    pool.install(move || swarmfl_core::sim::Sim::new(config, 7).unwrap().collect())
}

#[test]
fn a_run_with_estimated_gas_limits_is_deterministic_and_replays() {
    let one = authors_gas_run(1);
    assert!(one == authors_gas_run(2), "1 and 2 threads disagree");
    // Every robot transaction carries its estimate and limit in the log.
    let txs: Vec<_> = one
        .iter()
        .filter_map(|r| match r {
            Record::Event {
                event: Event::Ledger(LedgerEvent::Submit { tx }),
                ..
            } => Some(tx),
            _ => None,
        })
        .collect();
    assert!(!txs.is_empty());
    assert!(txs.iter().all(|tx| tx
        .gas
        .is_some_and(|g| g.limit == g.estimate + WEB3_GAS_MARGIN)));
    // The reducers re-derive every checkpoint from the events alone.
    let mut config = swarmfl_core::config::Preset::Smoke.config();
    config.contract.engine = ContractEngine::Evm;
    config.contract.gas_limit = GasLimitRule::Estimate;
    config.contract.gas_estimate_state = GasEstimateState::Head;
    let mut state = swarmfl_core::state::State::genesis(&config, 7).unwrap();
    for (i, record) in one.iter().enumerate() {
        swarmfl_core::replay::fold_record(&mut state, "run", i as u64, record).unwrap();
    }
    let gas = &state.ledger.head_state(0).evm.as_ref().unwrap().gas;
    assert!(gas.contains_key("accepted"), "{gas:?}");
    // Some submissions estimated on a head without another robot's waiting one run out of gas.
    assert!(
        gas.get("out_of_gas").is_some_and(|g| g.calls > 0),
        "{gas:?}"
    );
}

/// The smoke configuration under the evm engine with estimated gas limits on the pending block.
fn pending_config() -> swarmfl_core::config::Config {
    let mut config = swarmfl_core::config::Preset::Smoke.config();
    config.contract.engine = ContractEngine::Evm;
    config.contract.gas_limit = GasLimitRule::Estimate;
    config.validate().expect("a valid configuration");
    config
}

/// Robot `robot`'s submission of the genesis model (distance 0: accepted), not yet sent.
fn genesis_submission(state: &State, robot: u32) -> swarmfl_core::ledger::Tx {
    let p = state.ledger.current_params();
    let weights: Arc<[i64]> = state.ledger.head_state(robot).weights.clone();
    let call = Call::SubmitModel {
        weights,
        samples: 100 + u64::from(robot),
    };
    state.ledger.make_tx(robot, p.stake_units, call)
}

/// Robots `robots` submit at `at` (each into its own node) and node 0 receives their
/// transactions at `at`.
fn submissions_at_node_0(state: &mut State, robots: std::ops::RangeInclusive<u32>, at: SimTime) {
    for r in robots {
        let tx = genesis_submission(state, r);
        let hash = tx.hash_and_size().0;
        state.ledger.apply(at, &LedgerEvent::Submit { tx }).unwrap();
        let message = state.ledger.messages_sent();
        let send = LedgerEvent::Send {
            from: r,
            to: 0,
            items: vec![ItemRef::Tx(hash)],
            lost: false,
        };
        state.ledger.apply(at, &send).unwrap();
        state
            .ledger
            .apply(at, &LedgerEvent::Deliver { message })
            .unwrap();
    }
}

/// Node 0 seals its next block at `at` with what its mempool offers.
fn seal_at_node_0(state: &mut State, at: SimTime) {
    let (parent, _) = state.ledger.head(0);
    let txs = state.ledger.sealable_txs(0);
    let seal = LedgerEvent::Seal {
        node: 0,
        parent,
        txs,
        evidence: Vec::new(),
    };
    state.ledger.apply(at, &seal).unwrap();
}

#[test]
fn the_pending_estimate_sees_the_mempool_and_the_closing_submission_gets_its_gas() {
    let config = pending_config();
    let mut state = State::genesis(&config, 7).unwrap();
    let p = state.ledger.current_params().clone();
    let q = p.quorum;
    assert!(q >= 2 && q < p.robots, "{q}");
    // Round 1 closes in node 0's first block (sealed at `s`), so that a round's first
    // submission costs what a plain one does (no storage slot is fresh).
    let first = state.ledger.head_state(0).round;
    submissions_at_node_0(&mut state, 1..=q, SimTime(1_000));
    let s = SimTime(state.ledger.period_ms() + 5_000);
    seal_at_node_0(&mut state, s);
    assert_eq!(
        state.ledger.head_state(0).round,
        first + 1,
        "round 1 closed"
    );
    // Round 2: q - 1 submissions reach node 0's mempool 1 s later; robot 0's closes it.
    submissions_at_node_0(&mut state, 1..=q - 1, SimTime(s.0 + 1_000));
    assert_eq!(state.ledger.mempool(0).len(), (q - 1) as usize);
    let mine = genesis_submission(&state, 0);
    let (value, call) = (mine.value_units, &mine.call);
    let head = state.ledger.head_state(0).clone();
    let on_head = gas_limit::estimate(&head, &p, 0, value, call, WEB3_GAS_MARGIN).unwrap();
    // The miner rebuilt its block at `s` (the new head) and next at `s` + 3 s: 2 s after the
    // head it shows the head alone, from 3 s on the head and the q - 1 submissions.
    let lagging = state.ledger.pending_state(0, SimTime(s.0 + 2_000), 3_000);
    assert!(lagging.submissions.is_empty(), "the 3 s recommit");
    let pending = state.ledger.pending_state(0, SimTime(s.0 + 3_000), 3_000);
    assert_eq!(pending.submissions.len(), (q - 1) as usize);
    let current = state.ledger.pending_state(0, SimTime(s.0 + 2_000), 0);
    assert_eq!(
        current.submissions, pending.submissions,
        "recommit 0: the block always current"
    );
    let on_pending = gas_limit::estimate(&pending, &p, 0, value, call, WEB3_GAS_MARGIN).unwrap();
    assert!(
        on_pending.estimate > on_head.limit,
        "closing {on_pending:?} against plain {on_head:?}"
    );
    // Landing on that block's state: the head's estimate runs out of gas, the pending one's
    // closes the round.
    let mut landed = pending.clone();
    let out = landed.execute_with_gas(&p, 0, value, call, Some(on_head.limit));
    assert!(matches!(out, Outcome::OutOfGas { .. }), "{out:?}");
    let mut landed = pending.clone();
    let closed = landed.execute_with_gas(&p, 0, value, call, Some(on_pending.limit));
    assert!(matches!(closed, Outcome::Aggregated { .. }), "{closed:?}");
    // The node's state itself is untouched.
    assert_eq!(state.ledger.head_state(0).digest(), head.digest());
}

#[test]
fn a_second_submission_in_the_round_fails_the_pending_estimate_and_is_not_sent() {
    let config = pending_config();
    let mut state = State::genesis(&config, 7).unwrap();
    let p = state.ledger.current_params().clone();
    submissions_at_node_0(&mut state, 1..=1, SimTime(1_000));
    // Robot 1's first submission waits in its own node's mempool; it submits again.
    let again = genesis_submission(&state, 1);
    let pending = state.ledger.pending_state(1, SimTime(3_000), 3_000);
    let refused = gas_limit::estimate(&pending, &p, 1, again.value_units, &again.call, 0);
    assert_eq!(
        refused,
        Err(EstimateFailed {
            outcome: "duplicate"
        })
    );
    // On its head the round is empty: the head estimate lets it go (it lands as a duplicate).
    let head = state.ledger.head_state(1);
    assert!(gas_limit::estimate(head, &p, 1, again.value_units, &again.call, 0).is_ok());
    // A stake below the contract's is refused too (the authors' `require(msg.value >= ...)`).
    let short = gas_limit::estimate(head, &p, 2, p.stake_units - 1, &again.call, 0);
    assert_eq!(short.map_err(|e| e.outcome), Err("insufficient_stake"));
}

/// `authors-timing` for 1000 s (robots submit even when their node holds their submission of
/// the round) with the authors' gas limits estimated on `state`.
fn authors_timing_config(state: GasEstimateState) -> swarmfl_core::config::Config {
    let mut config = swarmfl_core::config::Preset::AuthorsTiming.config();
    config.run.duration_s = 1000.0;
    config.contract.engine = ContractEngine::Evm;
    config.contract.gas_limit = GasLimitRule::Estimate;
    config.contract.gas_estimate_state = state;
    config.validate().expect("a valid configuration");
    config
}

/// The records of `config`'s run at seed 1 on `threads` threads.
fn run_on(config: &swarmfl_core::config::Config, threads: usize) -> Vec<Record> {
    let config = config.clone();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    pool.install(move || swarmfl_core::sim::Sim::new(config, 1).unwrap().collect())
}

/// (phases skipped as `estimate_failed`, transactions submitted) of a run's records.
fn failed_and_sent(records: &[Record]) -> (usize, usize) {
    let mut failed = 0;
    let mut sent = 0;
    for r in records {
        match r {
            Record::Event {
                event: Event::Learn(report),
                ..
            } if report.action
                == (LearnAction::Skipped {
                    reason: SkipReason::EstimateFailed,
                }) =>
            {
                failed += 1
            }
            Record::Event {
                event: Event::Ledger(LedgerEvent::Submit { tx }),
                ..
            } => {
                assert!(tx.gas.is_some());
                sent += 1;
            }
            _ => {}
        }
    }
    (failed, sent)
}

#[test]
fn under_the_pending_estimate_refused_calls_are_not_sent_and_threads_agree() {
    let config = authors_timing_config(GasEstimateState::Pending);
    let one = run_on(&config, 1);
    assert!(one == run_on(&config, 2), "1 and 2 threads disagree");
    let (failed, sent) = failed_and_sent(&one);
    assert!(failed > 0 && sent > 0, "{failed} failed, {sent} sent");
    // The reducers re-derive every checkpoint; no transaction landed as a duplicate (every
    // second submission in a round was stopped at its estimate).
    let mut state = State::genesis(&config, 1).unwrap();
    for (i, record) in one.iter().enumerate() {
        swarmfl_core::replay::fold_record(&mut state, "run", i as u64, record).unwrap();
    }
    let gas = &state.ledger.head_state(0).evm.as_ref().unwrap().gas;
    assert!(gas.contains_key("aggregated"), "{gas:?}");
    assert!(!gas.contains_key("duplicate"), "{gas:?}");
}

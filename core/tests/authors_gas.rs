//! `contract.gas_limit = "estimate"` in a whole run: the records are a function of the seed (on
//! 1 and 2 threads), every robot transaction carries its estimate and limit, the reducers
//! re-derive every checkpoint from the events, and some submissions run out of gas.
#![cfg(feature = "evm")]

use swarmfl_core::config::{ContractEngine, WEB3_GAS_MARGIN};

/// A smoke run under the evm engine with the authors' gas limits, on `threads` pool threads.
fn authors_gas_run(threads: usize) -> Vec<swarmfl_core::event::Record> {
    let mut config = swarmfl_core::config::Preset::Smoke.config();
    config.contract.engine = ContractEngine::Evm;
    config.contract.gas_limit = swarmfl_core::config::GasLimitRule::Estimate;
    config.validate().expect("a valid configuration");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    pool.install(move || swarmfl_core::sim::Sim::new(config, 7).unwrap().collect())
}

#[test]
fn a_run_with_estimated_gas_limits_is_deterministic_and_replays() {
    use swarmfl_core::event::{Event, Record};
    use swarmfl_core::ledger::LedgerEvent;
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
    config.contract.gas_limit = swarmfl_core::config::GasLimitRule::Estimate;
    let mut state = swarmfl_core::state::State::genesis(&config, 7).unwrap();
    for (i, record) in one.iter().enumerate() {
        swarmfl_core::replay::fold_record(&mut state, "run", i as u64, record).unwrap();
    }
    let gas = &state.ledger.head_state(0).evm.as_ref().unwrap().gas;
    assert!(gas.contains_key("accepted"), "{gas:?}");
    // Some submissions estimated before another landed closed no round (11 at this seed).
    assert!(
        gas.get("out_of_gas").is_some_and(|g| g.calls > 0),
        "{gas:?}"
    );
}

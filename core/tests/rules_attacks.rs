//! Every aggregation rule and every attack in a short run: the Byzantine robots act (forged
//! submissions reach the log), and folding the log's events through the reducers re-makes
//! every checkpoint (the replay is bit-exact). Attack i runs under rule i mod 9, so 12 short
//! runs cover every rule and every attack; `scripts/rules-attacks-smoke.sh` runs all 108 pairs
//! at `smoke` length through the CLI.

use swarmfl_core::config::{Aggregation, ByzantineKind, Config, Preset, Rule};
use swarmfl_core::event::{Event, Record};
use swarmfl_core::metrics::LearnAction;
use swarmfl_core::sim::Sim;
use swarmfl_core::state::State;

use rayon::prelude::*;

/// Runs `config` with seed 11, folds every event into a state made from the header and checks
/// each checkpoint against the fold; `check` sees every record first. Returns the forged
/// submissions and the checkpoints. `label` names the run in failures.
fn run_and_fold(config: &Config, label: &str, mut check: impl FnMut(&Record)) -> (usize, usize) {
    config.validate().expect("a valid configuration");
    let seed = 11;
    let mut state = State::genesis(config, seed).expect("genesis");
    let (mut forged, mut checkpoints) = (0, 0);
    for record in Sim::new(config.clone(), seed).expect("a run") {
        check(&record);
        match record {
            Record::Event { time, event } => {
                if let Event::Learn(r) = &event {
                    forged += usize::from(matches!(r.action, LearnAction::Forged { .. }));
                }
                state
                    .apply(time, &event)
                    .expect("the run's own events fold");
            }
            Record::Checkpoint(c) => {
                assert_eq!(
                    state.checkpoint(c.time, c.cause),
                    c,
                    "{label}: checkpoint {checkpoints} differs on replay"
                );
                checkpoints += 1;
            }
        }
    }
    assert!(checkpoints > 10, "{label}: {checkpoints} checkpoints");
    assert!(forged > 0, "{label}: the Byzantine robots never submitted");
    (forged, checkpoints)
}

#[test]
fn every_rule_and_attack_runs_and_replays_bit_exactly() {
    // The 12 runs are independent: run them side by side (each asserts on its own).
    // (`plugin` needs an agent from outside: the Python package's tests run it.)
    let kinds: Vec<(usize, ByzantineKind)> = ByzantineKind::ALL
        .into_iter()
        .filter(|&k| !matches!(k, ByzantineKind::None | ByzantineKind::Plugin))
        .enumerate()
        .collect();
    kinds.into_par_iter().for_each(|(i, kind)| {
        let rule = Rule::ALL[i % Rule::ALL.len()];
        let mut config = Preset::Smoke.config();
        config.run.duration_s = 250.0;
        config.learn.learning_rate = 0.01;
        config.contract.rule = rule;
        config.contract.assumed_f = 1;
        config.byzantine.kind = kind;
        config.byzantine.count = 4;
        run_and_fold(
            &config,
            &format!("{} vs {}", rule.name(), kind.name()),
            |_| {},
        );
    });
}

/// Without a chain the attacks read a view built from the robot's stigmergy replica or the
/// server (`AggregationState::attacker_view`): every attack acts under `gossip` and `central`
/// (attack i under the aggregation i mod 2), and the baseline runs replay bit-exactly.
#[test]
fn every_attack_acts_under_gossip_and_central_and_replays_bit_exactly() {
    let aggregations = [Aggregation::Gossip, Aggregation::Central];
    // (`plugin` needs an agent from outside: the Python package's tests run it.)
    let kinds: Vec<(usize, ByzantineKind)> = ByzantineKind::ALL
        .into_iter()
        .filter(|&k| !matches!(k, ByzantineKind::None | ByzantineKind::Plugin))
        .enumerate()
        .collect();
    kinds.into_par_iter().for_each(|(i, kind)| {
        let aggregation = aggregations[i % 2];
        let mut config = Preset::Smoke.config();
        config.run.duration_s = 250.0;
        config.learn.aggregation = aggregation;
        config.byzantine.kind = kind;
        config.byzantine.count = 4;
        let label = format!("{} vs {}", aggregation.name(), kind.name());
        run_and_fold(&config, &label, |record| match record {
            Record::Event { event, .. } => assert!(
                !matches!(event, Event::Ledger(_)),
                "a {} run has no ledger events",
                aggregation.name()
            ),
            Record::Checkpoint(c) => assert!(
                c.aggregation.is_some(),
                "baseline checkpoints pin its state"
            ),
        });
    });
}

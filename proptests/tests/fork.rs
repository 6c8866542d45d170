//! Forks over random small runs: a run reconfigured at a random tick with random mid-run keys
//! (security on or off, stake, quorum, threshold, Byzantine robots, learning rate, duration)
//! keeps its history up to the fork point, folds back into every checkpoint, re-simulates
//! identically, and conserves tokens exactly on every node's head at every block.

use proptest::prelude::*;
use swarmfl_core::config::{ByzantineKind, Config, Preset};
use swarmfl_core::event::{CheckpointCause, Event, Reconfiguration, Record};
use swarmfl_core::sim::Sim;
use swarmfl_core::state::State;

fn base(robots: u32, security: bool) -> Config {
    let mut c = Preset::Smoke.config();
    c.world.robots = robots;
    c.run.duration_s = 120.0;
    c.learn.training_period_s = 30.0;
    c.learn.epochs = 2;
    c.contract.security = security;
    c.contract.penalised_ranks = c.contract.penalised_ranks.min(c.quorum() - 1);
    c.validate().expect("a valid base configuration");
    c
}

/// One random mid-run change, as `key=value` overrides.
fn change(c: &Config, which: u8, amount: u32) -> Vec<String> {
    match which % 7 {
        0 => vec![format!("contract.security={}", !c.contract.security)],
        1 => vec![
            "contract.security=true".into(),
            format!("contract.stake_tokens={}", 1 + amount % 8),
        ],
        2 => vec![
            format!(
                "contract.quorum_fraction={}",
                0.2 + f64::from(amount % 5) * 0.15
            ),
            "contract.penalised_ranks=0".into(),
        ],
        3 => vec![format!(
            "contract.outlier_threshold={}",
            0.001 * f64::from(1 + amount % 50)
        )],
        4 => vec![
            format!("byzantine.count={}", 1 + amount % (c.world.robots - 1)),
            format!(
                "byzantine.kind={}",
                ["faulty", "malicious", "smart"][(amount % 3) as usize]
            ),
        ],
        5 => vec![
            format!("learn.learning_rate={}", 0.001 * f64::from(1 + amount % 20)),
            format!("learn.training_period_s={}", 10 + amount % 40),
        ],
        _ => vec![format!("run.duration_s={}", 130 + amount % 60)],
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    #[test]
    fn a_fork_keeps_its_history_replays_and_conserves_tokens(
        seed in any::<u64>(),
        robots in 3u32..8,
        security in any::<bool>(),
        fork_tick in 1u64..1100,
        which in any::<u8>(),
        amount in any::<u32>(),
    ) {
        let root = base(robots, security);
        let overrides = change(&root, which, amount);
        let mut next = root.clone();
        for o in &overrides {
            next.set(o).expect("generated overrides are valid");
        }
        next.contract.penalised_ranks = next.contract.penalised_ranks.min(next.quorum() - 1);
        next.validate().expect("generated configurations are valid");
        if next.byzantine.count == 0 {
            next.byzantine.kind = ByzantineKind::None;
        }
        prop_assume!(!root.changed_keys(&next).is_empty());
        let at_ms = fork_tick * 100;
        let change = Reconfiguration { at_ms, overrides, config_toml: next.to_toml() };
        let parent: Vec<Record> = Sim::new(root.clone(), seed).unwrap().collect();
        let fork: Vec<Record> = Sim::forked(root.clone(), seed, std::slice::from_ref(&change))
            .unwrap()
            .collect();

        // The history up to the fork point is the parent's.
        let k = fork
            .iter()
            .position(|r| matches!(r, Record::Event { event: Event::Reconfigure(_), .. }))
            .expect("the fork reconfigures");
        prop_assert!(parent[..k] == fork[..k], "the fork rewrites its history");
        prop_assert_eq!(fork[k].time().0, at_ms);
        prop_assert!(matches!(
            &fork[k + 1],
            Record::Checkpoint(c) if c.cause == CheckpointCause::Reconfigure
        ));

        // Folding the fork's events rebuilds every checkpoint; tokens are conserved on every
        // node's head whenever a block is sealed.
        let mut state = State::genesis(&root, seed).unwrap();
        let total = state.ledger.params().total_units();
        let mut blocks = 0;
        for record in &fork {
            match record {
                Record::Event { time, event } => state.apply(*time, event).unwrap(),
                Record::Checkpoint(c) => {
                    prop_assert_eq!(&state.checkpoint(c.time, c.cause), c);
                    if matches!(c.cause, CheckpointCause::Block { .. }) {
                        blocks += 1;
                        for r in 0..robots {
                            prop_assert_eq!(state.ledger.head_state(r).total_units(), total);
                        }
                    }
                }
            }
        }
        prop_assert!(blocks > 0);
        for r in 0..robots {
            prop_assert_eq!(state.ledger.check_chain(r), Ok(()));
        }
        prop_assert_eq!(state.world.time().0, next.ticks() * 100);

        // And it is a pure function of (root, seed, reconfigurations).
        let again: Vec<Record> = Sim::forked(root, seed, &[change]).unwrap().collect();
        prop_assert!(fork == again);
    }
}

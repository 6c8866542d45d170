//! Determinism over random small configurations: the same seed and configuration give the same
//! records twice, and on one thread as on several (trainings of different robots run in
//! parallel and are combined in robot order).

use proptest::prelude::*;
use swarmfl_core::config::{ByzantineKind, Config, Preset};
use swarmfl_core::event::Record;
use swarmfl_core::sim::Sim;

fn records(config: &Config, seed: u64, threads: usize) -> Vec<Record> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool");
    pool.install(|| {
        Sim::new(config.clone(), seed)
            .expect("a valid config starts")
            .collect()
    })
}

fn config(robots: u32, duration_s: u32, security: bool, byzantine: u32, kind: u8) -> Config {
    let mut c = Preset::Smoke.config();
    c.world.robots = robots;
    c.run.duration_s = f64::from(duration_s);
    c.learn.training_period_s = 40.0;
    c.contract.security = security;
    c.contract.penalised_ranks = c.contract.penalised_ranks.min(c.quorum() - 1);
    c.byzantine.count = byzantine.min(robots - 1);
    c.byzantine.kind = match (c.byzantine.count, kind % 3) {
        (0, _) => ByzantineKind::None,
        (_, 0) => ByzantineKind::Faulty,
        (_, 1) => ByzantineKind::Malicious,
        _ => ByzantineKind::Smart,
    };
    c.validate().expect("generated configurations are valid");
    c
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, .. ProptestConfig::default() })]

    #[test]
    fn same_seed_same_records_on_one_thread_and_on_several(
        seed in any::<u64>(),
        robots in 3u32..9,
        duration_s in 60u32..130,
        security in any::<bool>(),
        byzantine in 0u32..3,
        kind in any::<u8>(),
    ) {
        let c = config(robots, duration_s, security, byzantine, kind);
        let one = records(&c, seed, 1);
        let many = records(&c, seed, 3);
        let again = records(&c, seed, 3);
        prop_assert!(one.iter().any(|r| r.kind() == "seal"), "blocks are sealed");
        if let Some(i) = one.iter().zip(&many).position(|(a, b)| a != b) {
            prop_assert!(false, "1 vs 3 threads diverge at record {i}: {} vs {}", one[i].kind(), many[i].kind());
        }
        prop_assert_eq!(one.len(), many.len());
        prop_assert!(many == again, "two runs on 3 threads differ");
    }
}

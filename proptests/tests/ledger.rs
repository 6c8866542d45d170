//! Property tests of the ledger: under random partitions, peer schedules, packet loss and
//! transfers, every node's canonical chain is valid (checked from scratch), its contract state
//! is a fresh replay of it, tokens are conserved, and after full connectivity every node
//! converges to the same head. The log replays to the same digest.

use std::sync::Arc;

use proptest::prelude::*;
use swarmfl_core::contract::{Call, ContractParams};
use swarmfl_core::ledger::synthetic::{drain, full_mesh};
use swarmfl_core::ledger::{Ledger, LedgerEvent, Network};
use swarmfl_core::{Config, RobotId, SimTime};

const TICK_MS: u64 = 100;

/// One stretch of the schedule: how long, and each robot's group (robots hear their group).
#[derive(Clone, Debug)]
struct Segment {
    secs: u64,
    groups: Vec<u8>,
}

#[derive(Clone, Debug)]
struct Transfer {
    at_s: u64,
    from: RobotId,
    to: RobotId,
    amount_units: u64,
}

fn scenario() -> impl Strategy<Value = (u32, u64, bool, Vec<Segment>, Vec<Transfer>)> {
    (3u32..=7, any::<u64>(), any::<bool>()).prop_flat_map(|(robots, seed, lossy)| {
        let segment = (5u64..60, prop::collection::vec(0u8..3, robots as usize))
            .prop_map(|(secs, groups)| Segment { secs, groups });
        let transfer = (0u64..300, 0..robots, 0..robots, 0u64..30_000_000_000).prop_map(
            |(at_s, from, to, amount_units)| Transfer {
                at_s,
                from,
                to,
                amount_units,
            },
        );
        (
            Just(robots),
            Just(seed),
            Just(lossy),
            prop::collection::vec(segment, 1..6),
            prop::collection::vec(transfer, 0..20),
        )
    })
}

fn groups_to_peers(groups: &[u8]) -> Vec<Vec<RobotId>> {
    (0..groups.len())
        .map(|i| {
            (0..groups.len())
                .filter(|&j| j != i && groups[j] == groups[i])
                .map(|j| j as RobotId)
                .collect()
        })
        .collect()
}

fn config(robots: u32, lossy: bool) -> Config {
    let mut c = Config::default();
    c.world.robots = robots;
    if lossy {
        c.ledger.packet_loss = 0.2;
        c.ledger.bandwidth_bytes_per_s = 5_000;
    }
    c
}

fn new_ledger(c: &Config, seed: u64) -> Ledger {
    Ledger::new(
        c,
        seed,
        ContractParams::from_config(c, Arc::from(vec![0i64; 4])),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn chains_stay_valid_and_converge_after_full_connectivity(
        (robots, seed, lossy, segments, transfers) in scenario()
    ) {
        let c = config(robots, lossy);
        let mut ledger = new_ledger(&c, seed);
        let mut net = Network::new(&c, seed);
        let mut log = Vec::new();
        let mut schedule: Vec<(u64, Vec<Vec<RobotId>>)> = Vec::new();
        let mut t_ms = 0;
        for s in &segments {
            schedule.push((t_ms, groups_to_peers(&s.groups)));
            t_ms += s.secs * 1000;
        }
        let partitioned_until_ms = t_ms;
        let end_ms = partitioned_until_ms + 60_000;
        let mut agreed_at_end = false;
        let mut t = 0;
        while t <= end_ms {
            let peers = if t >= partitioned_until_ms {
                full_mesh(robots)
            } else {
                schedule.iter().rev().find(|(start, _)| *start <= t).expect("segment").1.clone()
            };
            drain(&mut ledger, &mut net, SimTime(t), &peers, &mut log).unwrap();
            for tr in transfers.iter().filter(|tr| tr.at_s * 1000 == t) {
                let tx = ledger.make_tx(tr.from, 0, Call::Transfer { to: tr.to, amount_units: tr.amount_units });
                let event = LedgerEvent::Submit { tx };
                ledger.apply(SimTime(t), &event).unwrap();
                log.push((SimTime(t), event));
            }
            if t + 30_000 >= end_ms {
                let h0 = ledger.head(0).0;
                agreed_at_end |= (0..robots).all(|i| ledger.head(i).0 == h0);
            }
            t += TICK_MS;
        }
        prop_assert!(agreed_at_end, "nodes did not converge: {:?}", (0..robots).map(|i| ledger.head(i)).collect::<Vec<_>>());
        let total = ledger.head_state(0).total_units();
        for node in 0..robots {
            prop_assert_eq!(ledger.check_chain(node), Ok(()));
            let fresh = ledger.replay_state(ledger.canonical_chain(node)).unwrap();
            prop_assert_eq!(fresh.digest(), ledger.head_state(node).digest());
            prop_assert_eq!(ledger.head_state(node).total_units(), total);
        }
        let mut again = new_ledger(&c, seed);
        for (at, event) in &log {
            again.apply(*at, event).unwrap();
        }
        prop_assert_eq!(again.digest(), ledger.digest());
    }
}

//! Unit tests of the ledger: Clique rules, fork choice, reorgs against fresh replays,
//! partitions, rejections, determinism and replay.

use std::sync::Arc;

use super::synthetic::{drain, full_mesh, partition, Wanderers};
use super::*;
use crate::config::Config;
use crate::contract::{Call, ContractParams};

const TICK_MS: u64 = 100;

fn setup(robots: u32, seed: u64) -> (Config, Ledger, Network) {
    let mut config = Config::default();
    config.world.robots = robots;
    let params = ContractParams::from_config(&config, Arc::from(vec![0i64; 8]));
    let ledger = Ledger::new(&config, seed, params);
    let network = Network::new(&config, seed);
    (config, ledger, network)
}

fn transfer(to: RobotId, amount_units: u64) -> Call {
    Call::Transfer { to, amount_units }
}

/// A signed header on `parent` (honest keys), with overrides applied by `edit`.
fn header(
    ledger: &Ledger,
    parent: BlockHash,
    signer: RobotId,
    txs: &[TxHash],
    edit: impl Fn(&mut BlockHeader),
) -> BlockHeader {
    let (parent_height, parent_ms) = ledger.block(&parent).map_or((0, 0), |p| {
        (p.block.header.height, p.block.header.timestamp_ms)
    });
    let height = parent_height + 1;
    let mut h = BlockHeader {
        parent,
        height,
        timestamp_ms: parent_ms + ledger.period_ms(),
        signer,
        difficulty: ledger.expected_difficulty(&parent, signer),
        tx_root: block::tx_root(txs),
        signature: Sig::ZERO,
        evidence: Vec::new(),
    };
    edit(&mut h);
    if h.signature == Sig::ZERO && signer < ledger.robots() {
        h.signature = ledger.keys().sign(signer, &h.signing_hash());
    }
    h
}

fn wire_block(header: BlockHeader, txs: Vec<Tx>) -> Vec<u8> {
    WireItem::Block(WireBlock { header, txs }).encode()
}

/// Injects a block and returns its id.
fn inject_block(
    ledger: &mut Ledger,
    node: RobotId,
    at_ms: u64,
    header: BlockHeader,
    txs: Vec<Tx>,
) -> BlockHash {
    let hash = header.hash_and_size().0;
    ledger
        .apply(
            SimTime(at_ms),
            &LedgerEvent::Inject {
                node,
                bytes: wire_block(header, txs),
            },
        )
        .unwrap();
    hash
}

fn last_rejection(ledger: &Ledger, node: RobotId) -> Option<&'static str> {
    ledger
        .node(node)
        .rejections()
        .last()
        .map(|r| r.reason.kind())
}

/// Runs the network tick by tick from `from_ms` to `to_ms` with the peer sets `peers(t)`,
/// submitting the transactions `submit` returns at each tick.
fn run(
    ledger: &mut Ledger,
    net: &mut Network,
    (from_ms, to_ms): (u64, u64),
    peers: impl Fn(u64) -> Vec<Vec<RobotId>>,
    mut submit: impl FnMut(&Ledger, u64) -> Vec<Tx>,
    log: &mut Vec<(SimTime, LedgerEvent)>,
) {
    let mut t = from_ms;
    while t <= to_ms {
        drain(ledger, net, SimTime(t), &peers(t), log).unwrap();
        for tx in submit(ledger, t) {
            let event = LedgerEvent::Submit { tx };
            ledger.apply(SimTime(t), &event).unwrap();
            log.push((SimTime(t), event));
        }
        t += TICK_MS;
    }
}

fn every_head(ledger: &Ledger) -> Vec<BlockHash> {
    (0..ledger.robots()).map(|i| ledger.head(i).0).collect()
}

fn assert_state_is_a_fresh_replay(ledger: &Ledger) {
    for node in 0..ledger.robots() {
        ledger.check_chain(node).unwrap_or_else(|e| panic!("{e}"));
        let fresh = ledger.replay_state(ledger.canonical_chain(node)).unwrap();
        assert_eq!(
            fresh.digest(),
            ledger.head_state(node).digest(),
            "node {node}"
        );
        assert_eq!(fresh.total_units(), ledger.head_state(node).total_units());
    }
}

#[test]
fn difficulty_is_two_in_turn_and_one_out_of_turn() {
    let (_, ledger, _) = setup(5, 1);
    for (height, signer, expect) in [
        (1, 1, 2),
        (1, 0, 1),
        (5, 0, 2),
        (7, 2, 2),
        (7, 3, 1),
        (10, 0, 2),
    ] {
        assert_eq!(
            ledger.difficulty_in_turn(height, signer, None),
            expect,
            "height {height} signer {signer}"
        );
    }
}

#[test]
fn sealing_follows_the_signer_rules() {
    let (_, mut ledger, _) = setup(5, 2);
    let g = ledger.genesis();
    // Too early: before genesis + period.
    let early = LedgerEvent::Seal {
        node: 1,
        parent: g,
        txs: vec![],
        evidence: vec![],
    };
    let err = ledger.apply(SimTime(9_999), &early).unwrap_err();
    assert!(
        matches!(
            err,
            LedgerError::InvalidSeal {
                reason: RejectReason::TooEarly { .. },
                ..
            }
        ),
        "{err}"
    );
    // In turn (height 1, node 1): difficulty 2; out of turn (node 3): difficulty 1.
    ledger.apply(SimTime(10_000), &early).unwrap();
    let (b1, height) = ledger.head(1);
    assert_eq!(
        (height, ledger.block(&b1).unwrap().block.header.difficulty),
        (1, 2)
    );
    ledger
        .apply(
            SimTime(10_500),
            &LedgerEvent::Seal {
                node: 3,
                parent: g,
                txs: vec![],
                evidence: vec![],
            },
        )
        .unwrap();
    let (b3, _) = ledger.head(3);
    assert_eq!(ledger.block(&b3).unwrap().block.header.difficulty, 1);
    // Node 1 signed one of the last floor(5/2) = 2 blocks of its chain: it may not seal again,
    // neither at height 2 nor, after a block by node 2, at height 3.
    assert!(ledger.signed_recently(&b1, 1));
    let again = LedgerEvent::Seal {
        node: 1,
        parent: b1,
        txs: vec![],
        evidence: vec![],
    };
    let err = ledger.apply(SimTime(20_000), &again).unwrap_err();
    assert!(
        matches!(
            err,
            LedgerError::InvalidSeal {
                reason: RejectReason::RecentSigner(1),
                ..
            }
        ),
        "{err}"
    );
    let h2 = header(&ledger, b1, 2, &[], |_| {});
    let b2 = inject_block(&mut ledger, 1, 20_000, h2, vec![]);
    assert_eq!(ledger.head(1).0, b2);
    assert!(ledger.signed_recently(&b2, 1));
    let h3 = header(&ledger, b2, 4, &[], |_| {});
    let b4 = inject_block(&mut ledger, 1, 30_000, h3, vec![]);
    assert!(
        !ledger.signed_recently(&b4, 1),
        "two blocks later node 1 may seal again"
    );
    ledger
        .apply(
            SimTime(40_000),
            &LedgerEvent::Seal {
                node: 1,
                parent: b4,
                txs: vec![],
                evidence: vec![],
            },
        )
        .unwrap();
    assert_eq!(ledger.head(1).1, 4);
    // A node that saw a recent signer seal again rejects the block.
    let h = header(&ledger, b2, 2, &[], |_| {});
    inject_block(&mut ledger, 0, 40_000, h, vec![]);
    assert_eq!(last_rejection(&ledger, 0), Some("unknown_parent"));
    let hb1 = ledger.block(&b1).unwrap().block.header.clone();
    let hb2 = ledger.block(&b2).unwrap().block.header.clone();
    inject_block(&mut ledger, 0, 40_000, hb1, vec![]);
    inject_block(&mut ledger, 0, 40_000, hb2, vec![]);
    let h = header(&ledger, b2, 2, &[], |_| {});
    inject_block(&mut ledger, 0, 40_000, h, vec![]);
    assert_eq!(last_rejection(&ledger, 0), Some("recent_signer"));
}

#[test]
fn the_heaviest_chain_wins_ties_keep_the_head_and_reorgs_replay_exactly() {
    let (_, mut ledger, _) = setup(5, 3);
    let g = ledger.genesis();
    let keys = ledger.keys().clone();
    // Two competing transfers by robot 4 with nonce 0, one on each branch.
    let tx_a = Tx::signed(&keys, 4, 0, 0, transfer(0, 7));
    let tx_b = Tx::signed(&keys, 4, 0, 0, transfer(1, 9));
    let id = |tx: &Tx| tx.hash_and_size().0;
    // Branch B: out of turn (signer 2 at height 1): difficulty 1.
    let hb = header(&ledger, g, 2, &[id(&tx_b)], |_| {});
    let b = inject_block(&mut ledger, 0, 11_000, hb, vec![tx_b.clone()]);
    assert_eq!(ledger.head(0).0, b);
    // Branch A: in turn (signer 1 at height 1): difficulty 2 beats 1.
    let ha = header(&ledger, g, 1, &[id(&tx_a)], |_| {});
    let a = inject_block(&mut ledger, 0, 12_000, ha, vec![tx_a.clone()]);
    assert_eq!(ledger.head(0).0, a);
    assert_eq!(
        (ledger.node(0).reorgs(), ledger.node(0).deepest_reorg()),
        (1, 1)
    );
    assert_eq!(
        ledger.head_state(0).balances[0],
        ledger.params().initial_units + 7
    );
    assert_state_is_a_fresh_replay(&ledger);
    // C on B: signer 3 out of turn at height 2, total difficulty 2 = A's: the tie keeps A.
    let hc = header(&ledger, b, 3, &[], |_| {});
    let c = inject_block(&mut ledger, 0, 21_000, hc, vec![]);
    assert_eq!(ledger.head(0).0, a, "a tie keeps the current head");
    // D on C: signer 0 at height 3 (out of turn): total difficulty 3 beats 2.
    let hd = header(&ledger, c, 0, &[], |_| {});
    let d = inject_block(&mut ledger, 0, 31_000, hd, vec![]);
    assert_eq!(ledger.head(0).0, d);
    assert_eq!(ledger.canonical_chain(0), &[g, b, c, d]);
    assert_eq!(
        ledger.head_state(0).balances[1],
        ledger.params().initial_units + 9
    );
    assert_eq!(
        ledger.head_state(0).balances[0],
        ledger.params().initial_units
    );
    assert_eq!(ledger.node(0).reorgs(), 2);
    assert_state_is_a_fresh_replay(&ledger);
    // tx_a left the chain; its nonce is used on the new chain, so it left the mempool too.
    assert!(ledger.mempool(0).is_empty());
    // The forks: two children of genesis.
    assert_eq!(ledger.stats().forks_seen, 1);
    assert_eq!(ledger.receipts(&b).unwrap().len(), 1);
}

#[test]
fn forged_malformed_replayed_and_out_of_order_items_are_rejected_with_reasons() {
    let (_, mut ledger, _) = setup(4, 4);
    let g = ledger.genesis();
    let keys = ledger.keys().clone();
    let good = Tx::signed(&keys, 1, 0, 0, transfer(2, 5));
    let mut forged = good.clone();
    forged.call = transfer(3, 5);
    let mut stranger = good.clone();
    stranger.sender = 77;
    let future = Tx::signed(&keys, 1, 3, 0, transfer(2, 1));
    let far = Tx::signed(&keys, 1, 1 + MAX_NONCE_GAP + 1, 0, transfer(2, 1));
    let wire = |tx: &Tx| WireItem::Tx(tx.clone()).encode();
    let mut check = |bytes: Vec<u8>, expect: Option<&str>| {
        let before = ledger.node(0).rejections().len();
        let applied = ledger
            .apply(SimTime(1_000), &LedgerEvent::Inject { node: 0, bytes })
            .unwrap();
        let got = (ledger.node(0).rejections().len() > before)
            .then(|| last_rejection(&ledger, 0).unwrap());
        assert_eq!(got, expect, "{applied:?}");
    };
    check(wire(&good), None);
    check(wire(&forged), Some("bad_signature"));
    check(wire(&stranger), Some("unknown_sender"));
    check(vec![0xc1, 0x00, 0x13], Some("undecodable"));
    check(wire(&good)[..50].to_vec(), Some("undecodable"));
    check(wire(&future), None); // a future nonce waits in the mempool
    check(wire(&far), Some("nonce_gap"));
    assert_eq!(ledger.mempool(0).len(), 2);
    assert_eq!(
        ledger.sealable_txs(0),
        vec![good.hash_and_size().0],
        "nonce 3 waits for 1 and 2"
    );
    // Seal the good transaction, then replay it: rejected.
    let txs = ledger.sealable_txs(0);
    ledger
        .apply(
            SimTime(10_000),
            &LedgerEvent::Seal {
                node: 0,
                parent: g,
                txs,
                evidence: vec![],
            },
        )
        .unwrap();
    let replay = Tx::signed(&keys, 1, 0, 0, transfer(3, 1));
    fn check_rejected(ledger: &mut Ledger, bytes: Vec<u8>, at: u64, expect: &str) {
        let before = ledger.node(0).rejections().len();
        ledger
            .apply(SimTime(at), &LedgerEvent::Inject { node: 0, bytes })
            .unwrap();
        assert_eq!(
            ledger.node(0).rejections().len(),
            before + 1,
            "{expect} not rejected"
        );
        assert_eq!(last_rejection(ledger, 0), Some(expect));
    }
    check_rejected(&mut ledger, wire(&replay), 10_000, "replayed_nonce");
    // Blocks.
    let (head, _) = ledger.head(0);
    let t = 20_000;
    let l = &ledger;
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (
            wire_block(
                header(l, head, 2, &[], |h| h.signature = Sig([1; 64])),
                vec![],
            ),
            "bad_signature",
        ),
        (
            wire_block(
                header(l, head, 3, &[], |h| {
                    h.signature = l.keys().sign(1, &h.signing_hash())
                }),
                vec![],
            ),
            "bad_signature",
        ),
        (
            wire_block(header(l, head, 9, &[], |_| {}), vec![]),
            "unauthorised_signer",
        ),
        (
            wire_block(header(l, head, 2, &[], |h| h.difficulty = 1), vec![]),
            "bad_difficulty",
        ),
        (
            wire_block(header(l, head, 3, &[], |h| h.height = 5), vec![]),
            "bad_height",
        ),
        (
            wire_block(header(l, head, 3, &[], |h| h.timestamp_ms = 19_999), vec![]),
            "too_early",
        ),
        (
            wire_block(header(l, head, 3, &[], |h| h.timestamp_ms = 25_000), vec![]),
            "future_block",
        ),
        (
            wire_block(header(l, head, 0, &[], |_| {}), vec![]),
            "recent_signer",
        ),
        (
            wire_block(header(l, Digest::of(b"nowhere"), 2, &[], |_| {}), vec![]),
            "unknown_parent",
        ),
        (
            wire_block(
                header(l, head, 2, &[], |h| h.tx_root = Digest::of(b"x")),
                vec![],
            ),
            "bad_tx_root",
        ),
        (
            wire_block(
                header(l, head, 2, &[forged.hash_and_size().0], |_| {}),
                vec![forged.clone()],
            ),
            "bad_tx",
        ),
        (
            wire_block(
                header(l, head, 2, &[replay.hash_and_size().0], |_| {}),
                vec![replay.clone()],
            ),
            "bad_tx",
        ),
        (
            wire_block(
                header(l, head, 2, &[future.hash_and_size().0], |_| {}),
                vec![future.clone()],
            ),
            "bad_tx",
        ),
        (b"not a block".to_vec(), "undecodable"),
    ];
    let header_of_unknown_parent = header(l, Digest::of(b"nowhere"), 2, &[], |_| {});
    assert!(ledger.block(&header_of_unknown_parent.parent).is_none());
    for (bytes, expect) in cases {
        check_rejected(&mut ledger, bytes, t, expect);
    }
    // Nothing of it entered the node: the head and the state are those of the honest block.
    assert_eq!(ledger.head(0).0, head);
    assert_state_is_a_fresh_replay(&ledger);
    let stats = ledger.stats();
    assert_eq!(stats.rejections["bad_signature"], 3);
    assert_eq!(stats.rejections["bad_tx"], 3);
}

#[test]
fn invalid_events_are_errors_and_change_nothing() {
    let (_, mut ledger, _) = setup(3, 5);
    let g = ledger.genesis();
    let keys = ledger.keys().clone();
    ledger
        .apply(
            SimTime(500),
            &LedgerEvent::Submit {
                tx: Tx::signed(&keys, 0, 0, 0, transfer(1, 1)),
            },
        )
        .unwrap();
    let before = ledger.digest();
    let tx_unknown = Digest::of(b"t");
    let cases: Vec<(u64, LedgerEvent)> = vec![
        (400, LedgerEvent::Deliver { message: 0 }),
        (600, LedgerEvent::Deliver { message: 0 }),
        (
            600,
            LedgerEvent::Inject {
                node: 3,
                bytes: vec![],
            },
        ),
        (
            600,
            LedgerEvent::Seal {
                node: 7,
                parent: g,
                txs: vec![],
                evidence: vec![],
            },
        ),
        (
            10_000,
            LedgerEvent::Seal {
                node: 1,
                parent: Digest::of(b"p"),
                txs: vec![],
                evidence: vec![],
            },
        ),
        (
            10_000,
            LedgerEvent::Seal {
                node: 1,
                parent: g,
                txs: vec![tx_unknown],
                evidence: vec![],
            },
        ),
        (
            600,
            LedgerEvent::Send {
                from: 0,
                to: 0,
                items: vec![ItemRef::Block(g)],
                lost: false,
            },
        ),
        (
            600,
            LedgerEvent::Send {
                from: 0,
                to: 1,
                items: vec![],
                lost: false,
            },
        ),
        (
            600,
            LedgerEvent::Send {
                from: 1,
                to: 0,
                items: vec![ItemRef::Tx(tx_unknown)],
                lost: false,
            },
        ),
        (
            600,
            LedgerEvent::Send {
                from: 1,
                to: 5,
                items: vec![ItemRef::Block(g)],
                lost: false,
            },
        ),
        (
            600,
            LedgerEvent::Submit {
                tx: Tx::signed(&keys, 0, 0, 0, transfer(1, 1)).clone_with_sender(9),
            },
        ),
    ];
    for (at, event) in cases {
        assert!(
            ledger.apply(SimTime(at), &event).is_err(),
            "{event:?} was applied"
        );
        assert_eq!(ledger.digest(), before, "{event:?} changed the state");
    }
}

impl Tx {
    fn clone_with_sender(mut self, sender: RobotId) -> Tx {
        self.sender = sender;
        self
    }
}

/// A swarm of `robots` wandering for `secs` seconds, each robot submitting a transfer every
/// 30 s; returns the ledger and the log.
fn wander(
    robots: u32,
    seed: u64,
    secs: u64,
    tweak: impl Fn(&mut Config),
) -> (Ledger, Vec<(SimTime, LedgerEvent)>) {
    let (mut config, _, _) = setup(robots, seed);
    tweak(&mut config);
    let params = ContractParams::from_config(&config, Arc::from(vec![0i64; 8]));
    let mut ledger = Ledger::new(&config, seed, params);
    let mut net = Network::new(&config, seed);
    let mut swarm = Wanderers::new(robots, seed, 5.0, 2.0, 0.05);
    let mut log = Vec::new();
    let mut t = 0;
    while t <= secs * 1000 {
        if t % 500 == 0 {
            swarm.step(0.5);
        }
        drain(&mut ledger, &mut net, SimTime(t), &swarm.peers(), &mut log).unwrap();
        if t % 30_000 == 0 && t > 0 {
            let r = ((t / 30_000) % u64::from(robots)) as RobotId;
            let tx = ledger.make_tx(r, 0, transfer((r + 1) % robots, 1_000));
            let event = LedgerEvent::Submit { tx };
            ledger.apply(SimTime(t), &event).unwrap();
            log.push((SimTime(t), event));
        }
        t += TICK_MS;
    }
    (ledger, log)
}

fn replay(
    config_robots: u32,
    seed: u64,
    log: &[(SimTime, LedgerEvent)],
    tweak: impl Fn(&mut Config),
) -> Ledger {
    let (mut config, _, _) = setup(config_robots, seed);
    tweak(&mut config);
    let params = ContractParams::from_config(&config, Arc::from(vec![0i64; 8]));
    let mut ledger = Ledger::new(&config, seed, params);
    for (at, event) in log {
        ledger.apply(*at, event).unwrap();
    }
    ledger
}

#[test]
fn same_seed_same_digests_and_the_log_replays_to_the_same_state() {
    let (a, log_a) = wander(6, 11, 400, |_| {});
    let (b, log_b) = wander(6, 11, 400, |_| {});
    assert_eq!(log_a, log_b);
    assert_eq!(a.digest(), b.digest());
    let (c, _) = wander(6, 12, 400, |_| {});
    assert_ne!(a.digest(), c.digest());
    // The log round-trips through rmp-serde and replays to the same digests.
    let bytes = rmp_serde::to_vec(&log_a).unwrap();
    let back: Vec<(SimTime, LedgerEvent)> = rmp_serde::from_slice(&bytes).unwrap();
    let r = replay(6, 11, &back, |_| {});
    assert_eq!(r.digest(), a.digest());
    for node in 0..6 {
        assert_eq!(r.node_digest(node), a.node_digest(node));
        assert_eq!(r.head_state(node).digest(), a.head_state(node).digest());
    }
    assert_eq!(r.stats(), a.stats());
    let stats = a.stats();
    assert!(stats.canonical_height >= 30, "{stats:?}");
    assert!(
        stats.submissions >= 13 && stats.inclusion.count >= 10,
        "{stats:?}"
    );
    assert_state_is_a_fresh_replay(&a);
}

#[test]
fn lossy_narrow_links_still_converge_and_replay() {
    let tweak = |c: &mut Config| {
        c.ledger.packet_loss = 0.3;
        c.ledger.bandwidth_bytes_per_s = 2_000;
    };
    let (a, log) = wander(5, 21, 300, tweak);
    let stats = a.stats();
    assert!(
        stats.messages_lost > 0 && stats.canonical_height >= 20,
        "{stats:?}"
    );
    assert!(log
        .iter()
        .any(|(_, e)| matches!(e, LedgerEvent::Send { lost: true, .. })));
    // Deliveries come later than their sends with a narrow link.
    let r = replay(5, 21, &log, tweak);
    assert_eq!(r.digest(), a.digest());
    assert_state_is_a_fresh_replay(&a);
}

#[test]
fn a_partitioned_swarm_grows_two_chains_and_heals_to_one() {
    let robots = 6;
    let (_, mut ledger, mut net) = setup(robots, 7);
    let mut log = Vec::new();
    let mut submit = |l: &Ledger, t: u64| {
        if t.is_multiple_of(20_000) && t > 0 {
            let r = ((t / 20_000) % u64::from(robots)) as RobotId;
            vec![l.make_tx(r, 0, transfer((r + 2) % robots, 10))]
        } else {
            vec![]
        }
    };
    run(
        &mut ledger,
        &mut net,
        (0, 35_000),
        |_| full_mesh(robots),
        &mut submit,
        &mut log,
    );
    let common = ledger.head(0);
    assert!(every_head(&ledger).iter().all(|h| *h == common.0));
    // Partition {0, 1} | {2, 3, 4, 5} for 200 s.
    run(
        &mut ledger,
        &mut net,
        (35_100, 235_000),
        |_| partition(robots, 2),
        &mut submit,
        &mut log,
    );
    let (left, right) = (ledger.head(0), ledger.head(5));
    assert_ne!(left.0, right.0);
    assert!(
        left.1 > common.1 && right.1 > common.1,
        "both sides grew: {left:?} {right:?}"
    );
    assert!(
        right.1 > left.1,
        "the larger side keeps sealing; the smaller stalls on the recent-signer rule"
    );
    assert_eq!(ledger.head(1).0, left.0);
    assert_eq!(ledger.head(2).0, right.0);
    // Heal.
    run(
        &mut ledger,
        &mut net,
        (235_100, 265_000),
        |_| full_mesh(robots),
        &mut submit,
        &mut log,
    );
    let heads = every_head(&ledger);
    assert!(heads.iter().all(|h| *h == heads[0]), "healed to one chain");
    assert!(
        ledger.canonical_chain(0).contains(&right.0),
        "the heavier side's chain won"
    );
    let stats = ledger.stats();
    assert!(
        stats.reorgs >= 2 && stats.deepest_reorg >= 1 && stats.forks_seen >= 1,
        "{stats:?}"
    );
    assert!(
        stats.stored_bytes_max > stats.chain_bytes_max,
        "the losing side holds its old branch too"
    );
    assert_state_is_a_fresh_replay(&ledger);
    // Transfers submitted on the losing side went back to the mempool and were sealed again.
    assert_eq!(stats.not_propagated, 0, "{stats:?}");
    let r = replay(robots, 7, &log, |_| {});
    assert_eq!(r.digest(), ledger.digest());
}

#[test]
fn sealable_txs_follow_nonce_order_and_arrival_across_senders() {
    let (_, mut ledger, _) = setup(3, 9);
    let keys = ledger.keys().clone();
    let t = |sender, nonce| Tx::signed(&keys, sender, nonce, 0, transfer(0, 1));
    // Arrivals at node 0: (2,1) (1,0) (2,0) (1,1) (2,0') duplicate nonce.
    let txs = [
        t(2, 1),
        t(1, 0),
        t(2, 0),
        t(1, 1),
        Tx::signed(&keys, 2, 0, 0, transfer(1, 1)),
    ];
    for tx in &txs {
        ledger
            .apply(
                SimTime(0),
                &LedgerEvent::Inject {
                    node: 0,
                    bytes: WireItem::Tx(tx.clone()).encode(),
                },
            )
            .unwrap();
    }
    let id = |tx: &Tx| tx.hash_and_size().0;
    let dup = id(&txs[2]).min(id(&txs[4]));
    // Sender 1's run starts at arrival 1; sender 2's nonce-0 choice is the lower id.
    let got = ledger.sealable_txs(0);
    assert_eq!(got.len(), 4);
    assert_eq!(got[0], id(&txs[1]));
    assert!(got.contains(&dup) && got.contains(&id(&txs[0])) && got.contains(&id(&txs[3])));
    let pos = |h| got.iter().position(|g| *g == h).unwrap();
    assert!(pos(dup) < pos(id(&txs[0])) && pos(id(&txs[1])) < pos(id(&txs[3])));
    // make_tx continues after the pending nonces of the robot's own node.
    ledger
        .apply(SimTime(0), &LedgerEvent::Submit { tx: t(0, 0) })
        .unwrap();
    assert_eq!(ledger.make_tx(0, 0, transfer(1, 1)).nonce, 1);
    assert_eq!(
        ledger.make_tx(1, 0, transfer(1, 1)).nonce,
        0,
        "node 1 has no pending txs"
    );
}

#[test]
fn a_node_that_may_not_seal_on_its_head_moves_to_an_equally_heavy_branch() {
    let (_, mut ledger, _) = setup(4, 13);
    let g = ledger.genesis();
    fn add(ledger: &mut Ledger, at_ms: u64, parent: BlockHash, signer: RobotId) -> BlockHash {
        let h = header(ledger, parent, signer, &[], |_| {});
        inject_block(ledger, 0, at_ms, h, vec![])
    }
    // A: node 1 in turn (2), then node 0 out of turn (1): total 3, last two signers {1, 0}.
    let a1 = add(&mut ledger, 10_000, g, 1);
    let a2 = add(&mut ledger, 20_000, a1, 0);
    assert!(ledger.signed_recently(&a2, 0), "node 0 may not seal on A");
    // B: node 3 out of turn (1), then node 2 in turn (2): total 3 as well.
    let b1 = add(&mut ledger, 20_000, g, 3);
    assert_eq!(ledger.head(0).0, a2);
    let b2 = add(&mut ledger, 20_000, b1, 2);
    assert_eq!(
        ledger.block(&b2).unwrap().total_difficulty,
        ledger.block(&a2).unwrap().total_difficulty
    );
    assert_eq!(
        ledger.head(0).0,
        b2,
        "stuck on A, node 0 moves to B where it may seal"
    );
    // Node 3 is not stuck on A: the tie keeps its head.
    for h in [a1, a2, b1, b2] {
        let header = ledger.block(&h).unwrap().block.header.clone();
        inject_block(&mut ledger, 3, 20_000, header, vec![]);
    }
    assert_eq!(ledger.head(3).0, a2);
    assert_state_is_a_fresh_replay(&ledger);
}

#[test]
fn a_forged_body_does_not_poison_the_honest_block() {
    let (_, mut ledger, _) = setup(3, 17);
    let g = ledger.genesis();
    let keys = ledger.keys().clone();
    let tx = Tx::signed(&keys, 2, 0, 0, transfer(0, 3));
    let other = Tx::signed(&keys, 2, 0, 0, transfer(1, 3));
    let h = header(&ledger, g, 1, &[tx.hash_and_size().0], |_| {});
    let id = h.hash_and_size().0;
    inject_block(&mut ledger, 0, 10_000, h.clone(), vec![other]);
    assert_eq!(last_rejection(&ledger, 0), Some("bad_tx_root"));
    inject_block(&mut ledger, 0, 10_000, h, vec![tx]);
    assert_eq!(ledger.head(0).0, id);
    assert_eq!(ledger.receipts(&id).unwrap().len(), 1);
}

#[test]
fn event_times_do_not_depend_on_how_often_the_network_is_polled() {
    let logs: Vec<Vec<(SimTime, LedgerEvent)>> = [100u64, 700, 100_000]
        .iter()
        .map(|&step_ms| {
            let (_, mut ledger, mut net) = setup(5, 19);
            let keys = ledger.keys().clone();
            let tx = Tx::signed(&keys, 3, 0, 0, transfer(4, 1));
            ledger
                .apply(SimTime(0), &LedgerEvent::Submit { tx })
                .unwrap();
            let peers = partition(5, 2);
            let mut log = Vec::new();
            let mut t = 0;
            while t < 100_000 {
                t = (t + step_ms).min(100_000);
                drain(&mut ledger, &mut net, SimTime(t), &peers, &mut log).unwrap();
            }
            log
        })
        .collect();
    assert!(logs[0].len() > 20);
    assert_eq!(logs[0], logs[1]);
    assert_eq!(logs[0], logs[2]);
}

#[test]
fn a_network_resumes_a_replayed_ledger_deterministically() {
    let tweak = |c: &mut Config| c.ledger.bandwidth_bytes_per_s = 500;
    let (_, log) = wander(5, 23, 200, tweak);
    let cut = log.len() / 2;
    let (mut config, _, _) = setup(5, 23);
    tweak(&mut config);
    let resumed = |log: &[(SimTime, LedgerEvent)]| {
        let mut ledger = replay(5, 23, log, tweak);
        let mut net = Network::resume(&config, 23, &ledger);
        let mut more = Vec::new();
        let start = ledger.now().0;
        run(
            &mut ledger,
            &mut net,
            (start, start + 100_000),
            |_| full_mesh(5),
            |_, _| vec![],
            &mut more,
        );
        (ledger.digest(), more)
    };
    let (a, more) = resumed(&log[..cut]);
    assert_eq!((a, more.clone()), resumed(&log[..cut]));
    assert!(more
        .iter()
        .any(|(_, e)| matches!(e, LedgerEvent::Seal { .. })));
}

#[test]
fn a_peer_that_forgot_a_refused_transaction_is_sent_it_again() {
    // Node 1 refuses node 0's transaction (the same nonce with a lower id is pending there),
    // then forgets the refusal when more than MAX_REFUSED_KEPT others follow: the gossip, which
    // skips what a peer has seen, must offer it again. Node 1 never gossips to node 0.
    let (_, mut ledger, mut net) = setup(3, 29);
    let keys = ledger.keys().clone();
    let mut pair: Vec<Tx> = (1..=2)
        .map(|amount| Tx::signed(&keys, 2, 0, 0, transfer(1, amount)))
        .collect();
    pair.sort_by_key(|tx| tx.hash_and_size().0);
    let (low, high) = (pair[0].clone(), pair[1].clone());
    let high_id = high.hash_and_size().0;
    let inject = |ledger: &mut Ledger, node: RobotId, at_ms: u64, tx: &Tx| {
        let bytes = WireItem::Tx(tx.clone()).encode();
        ledger
            .apply(SimTime(at_ms), &LedgerEvent::Inject { node, bytes })
            .unwrap();
    };
    inject(&mut ledger, 1, 0, &low);
    inject(&mut ledger, 0, 0, &high);
    let peers = vec![vec![1], vec![], vec![]];
    let mut log = Vec::new();
    drain(&mut ledger, &mut net, SimTime(1_000), &peers, &mut log).unwrap();
    assert_eq!(last_rejection(&ledger, 1), Some("nonce_taken"));
    assert!(ledger.knows_tx(1, &high_id));
    for i in 0..MAX_REFUSED_KEPT as u64 {
        let mut forged = Tx::signed(&keys, 2, 1, 0, transfer(0, i));
        forged.call = transfer(1, i);
        inject(&mut ledger, 1, 1_100, &forged);
    }
    assert!(!ledger.knows_tx(1, &high_id), "the refusal is forgotten");
    let sent_before = log.len();
    drain(&mut ledger, &mut net, SimTime(2_000), &peers, &mut log).unwrap();
    let offered = log[sent_before..].iter().any(|(_, e)| {
        matches!(e, LedgerEvent::Send { from: 0, to: 1, items, .. }
            if items == &vec![ItemRef::Tx(high_id)])
    });
    assert!(offered, "{:?}", &log[sent_before..]);
    assert_eq!(last_rejection(&ledger, 1), Some("nonce_taken"));
}

/// The shared storage's transactions: how many, and their encoded bytes.
fn storage(ledger: &Ledger) -> (usize, u64) {
    let bytes = ledger.txs.values().map(|e| u64::from(e.size_bytes)).sum();
    (ledger.txs.len(), bytes)
}

#[test]
fn refused_transactions_leave_the_shared_storage() {
    // One key signs 3,000 variants that every node refuses (each is too far ahead of the
    // sender's nonce): none may stay stored, or the key grows every node's memory at will.
    let (_, mut ledger, _) = setup(3, 41);
    let keys = ledger.keys().clone();
    let inject = |ledger: &mut Ledger, node: RobotId, at_ms: u64, tx: &Tx| {
        let bytes = WireItem::Tx(tx.clone()).encode();
        ledger
            .apply(SimTime(at_ms), &LedgerEvent::Inject { node, bytes })
            .unwrap();
    };
    for i in 0..3_000u64 {
        let far = Tx::signed(&keys, 2, MAX_NONCE_GAP + 1 + i, 0, transfer(1, i));
        for node in 0..3 {
            inject(&mut ledger, node, 1_000, &far);
        }
    }
    assert_eq!(ledger.node(0).rejected_total(), 3_000);
    assert_eq!(storage(&ledger), (0, 0), "refused variants stay stored");
    // A replaced transaction that no other node holds leaves too; its replacement stays.
    let mut pair: Vec<Tx> = (1..=2)
        .map(|amount| Tx::signed(&keys, 2, 0, 0, transfer(1, amount)))
        .collect();
    pair.sort_by_key(|tx| tx.hash_and_size().0);
    inject(&mut ledger, 0, 2_000, &pair[1]);
    inject(&mut ledger, 0, 2_000, &pair[0]);
    assert_eq!(ledger.stats().mempool_replaced, 1);
    let low = pair[0].hash_and_size().0;
    assert_eq!(ledger.txs.keys().copied().collect::<Vec<_>>(), vec![low]);
    // A refused variant that comes again is refused again, stored or not.
    inject(&mut ledger, 1, 3_000, &pair[1]);
    assert_eq!(ledger.mempool(1), vec![pair[1].hash_and_size().0]);
}

#[test]
fn a_reorg_returns_abandoned_transactions_through_the_mempool_caps() {
    // A block on genesis carries 308 transactions: 20 from sender 1, 16 from each of 18
    // others. A heavier sibling without them abandons it: at most MEMPOOL_PER_SENDER per
    // sender and MEMPOOL_MAX in all may return, as if they had arrived new.
    let (_, mut ledger, _) = setup(20, 43);
    let g = ledger.genesis();
    let keys = ledger.keys().clone();
    let txs: Vec<Tx> = (1..20)
        .flat_map(|sender| (0..if sender == 1 { 20 } else { 16 }).map(move |n| (sender, n)))
        .map(|(sender, nonce)| Tx::signed(&keys, sender, nonce, 0, transfer(0, 1)))
        .collect();
    let ids: Vec<TxHash> = txs.iter().map(|tx| tx.hash_and_size().0).collect();
    // Out of turn (signer 2 at height 1, difficulty 1), then in turn (signer 1, difficulty 2).
    let full = header(&ledger, g, 2, &ids, |_| {});
    let full = inject_block(&mut ledger, 0, 11_000, full, txs);
    assert_eq!(ledger.head(0).0, full);
    let empty = header(&ledger, g, 1, &[], |_| {});
    let empty = inject_block(&mut ledger, 0, 12_000, empty, vec![]);
    assert_eq!(ledger.head(0).0, empty);
    let mempool = ledger.mempool(0);
    let busiest = (1..20)
        .map(|sender| {
            mempool
                .iter()
                .filter(|h| ledger.tx(h).unwrap().tx.sender == sender)
                .count()
        })
        .max()
        .unwrap();
    assert!(
        mempool.len() <= MEMPOOL_MAX as usize && busiest <= MEMPOOL_PER_SENDER as usize,
        "{} pending, {busiest} from one sender",
        mempool.len()
    );
    assert_eq!(mempool.len(), MEMPOOL_MAX as usize);
    // The same selection as for new arrivals: the lowest nonces of each sender stay.
    for sender in 1..20 {
        let nonces: Vec<u64> = mempool
            .iter()
            .map(|h| &ledger.tx(h).unwrap().tx)
            .filter(|tx| tx.sender == sender)
            .map(|tx| tx.nonce)
            .collect();
        assert_eq!(nonces, (0..nonces.len() as u64).collect::<Vec<_>>());
    }
}

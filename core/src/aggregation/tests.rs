use std::sync::Arc;

use super::*;
use crate::config::Preset;

fn config(kind: Aggregation, robots: u32) -> Config {
    let mut c = Preset::Smoke.config();
    c.world.robots = robots;
    c.learn.aggregation = kind;
    c
}

fn model(values: &[i64]) -> Arc<[i64]> {
    Arc::from(values.to_vec())
}

fn fold(state: &mut AggregationState, events: &[AggregationEvent]) {
    for (i, e) in events.iter().enumerate() {
        state.apply(SimTime(i as u64), e).unwrap();
    }
}

fn write(robot: RobotId, samples: u64, w: &[i64]) -> AggregationEvent {
    AggregationEvent::Write {
        robot,
        samples,
        weights: model(w),
    }
}

#[test]
fn the_merge_averages_by_samples_once_a_quorum_is_held() {
    // 4 robots, quorum floor(0.5 * 4) = 2.
    let mut s = AggregationState::new(&config(Aggregation::Gossip, 4), model(&[0, 0]));
    assert_eq!(s.quorum(), 2);
    fold(
        &mut s,
        &[
            write(0, 1, &[10, -10]),
            AggregationEvent::Merge { robot: 0 },
        ],
    );
    // Below the quorum the robot continues from its own last model.
    assert_eq!(&s.current(0).weights[..], &[10, -10]);
    assert_eq!(s.current(0).round, 0);
    assert!(s.aggregations.is_empty());
    let entries = vec![EntryId { key: 1, clock: 1 }];
    fold(
        &mut s,
        &[
            write(1, 3, &[2, 2]),
            AggregationEvent::Send {
                from: 1,
                to: 0,
                entries,
                lost: false,
            },
            AggregationEvent::Deliver { message: 0 },
            AggregationEvent::Merge { robot: 0 },
        ],
    );
    // (1 * 10 + 3 * 2) / 4 = 4, (1 * -10 + 3 * 2) / 4 = -1.
    assert_eq!(&s.current(0).weights[..], &[4, -1]);
    assert_eq!(s.current(0).round, 1);
    assert_eq!(s.aggregations.len(), 1);
    assert_eq!(s.aggregations[0].robot, Some(0));
    assert_eq!(s.current(0).previous.as_deref(), Some(&[10i64, -10][..]));
    // Robot 1 never heard of robot 0: below the quorum.
    assert_eq!(&s.preview(1).weights[..], &[2, 2]);
}

#[test]
fn the_newest_version_wins_and_stale_or_lost_messages_change_nothing() {
    let mut s = AggregationState::new(&config(Aggregation::Gossip, 3), model(&[0]));
    fold(
        &mut s,
        &[
            write(2, 1, &[5]),
            AggregationEvent::Send {
                from: 2,
                to: 0,
                entries: vec![EntryId { key: 2, clock: 1 }],
                lost: false,
            },
            write(2, 1, &[7]),
            AggregationEvent::Send {
                from: 2,
                to: 0,
                entries: vec![EntryId { key: 2, clock: 2 }],
                lost: false,
            },
            AggregationEvent::Send {
                from: 2,
                to: 1,
                entries: vec![EntryId { key: 2, clock: 2 }],
                lost: true,
            },
            // The newer version arrives first; the older one must not overwrite it.
            AggregationEvent::Deliver { message: 1 },
            AggregationEvent::Deliver { message: 0 },
        ],
    );
    let held: Vec<(EntryId, i64)> = s
        .stigmergy
        .held(0)
        .iter()
        .map(|e| (e.id, e.weights[0]))
        .collect();
    assert_eq!(held, vec![(EntryId { key: 2, clock: 2 }, 7)]);
    assert!(
        s.stigmergy.held(1).is_empty(),
        "the lost message never arrives"
    );
    assert_eq!(s.stigmergy.messages_lost, 1);
    // Lost messages were still sent: the sender paid for three.
    let b1 = Entry::new(EntryId { key: 2, clock: 1 }, 1, model(&[5])).bytes;
    let b2 = Entry::new(EntryId { key: 2, clock: 2 }, 1, model(&[7])).bytes;
    assert_eq!(s.bytes_sent[2], b1 + 2 * b2);
    assert_eq!(s.stigmergy.bytes_received[0], b1 + b2);
    assert!(s
        .apply(SimTime(9), &AggregationEvent::Deliver { message: 2 })
        .is_err());
}

#[test]
fn a_robot_cannot_send_what_it_does_not_hold_and_events_must_fit_the_aggregation() {
    let mut s = AggregationState::new(&config(Aggregation::Gossip, 3), model(&[0]));
    let forged = AggregationEvent::Send {
        from: 0,
        to: 1,
        entries: vec![EntryId { key: 2, clock: 1 }],
        lost: false,
    };
    assert!(s
        .apply(SimTime(0), &forged)
        .unwrap_err()
        .contains("holds version 0"));
    let upload = AggregationEvent::Upload {
        robot: 0,
        samples: 1,
        weights: model(&[1]),
    };
    assert!(s.apply(SimTime(0), &upload).unwrap_err().contains("gossip"));
    let mut chain = AggregationState::new(&config(Aggregation::Chain, 3), model(&[0]));
    assert!(chain
        .apply(SimTime(0), &AggregationEvent::Merge { robot: 0 })
        .is_err());
}

#[test]
fn the_outlier_filter_leaves_out_distant_models_but_never_the_robots_own() {
    let mut c = config(Aggregation::Gossip, 4);
    c.learn.gossip_outlier_filter = true;
    c.contract.weight_scale = 100;
    c.contract.outlier_threshold = 0.05;
    // Limit: 0.05 * 100 * 2 weights = 10 units of L1 distance to the current model [0, 0].
    let mut s = AggregationState::new(&c, model(&[0, 0]));
    fold(
        &mut s,
        &[
            write(0, 1, &[40, 40]),
            write(1, 1, &[3, 3]),
            write(2, 1, &[100, -100]),
            AggregationEvent::Send {
                from: 1,
                to: 0,
                entries: vec![EntryId { key: 1, clock: 1 }],
                lost: false,
            },
            AggregationEvent::Send {
                from: 2,
                to: 0,
                entries: vec![EntryId { key: 2, clock: 1 }],
                lost: false,
            },
            AggregationEvent::Deliver { message: 0 },
            AggregationEvent::Deliver { message: 1 },
            AggregationEvent::Merge { robot: 0 },
        ],
    );
    // Robot 2's model (distance 200) is left out; robot 0's own (distance 80) is kept.
    assert_eq!(&s.current(0).weights[..], &[22, 22]);
    assert_eq!(s.aggregations[0].models.len(), 2);
}

#[test]
fn the_central_server_counts_uploads_and_downloads() {
    let mut s = AggregationState::new(&config(Aggregation::Central, 2), model(&[0, 0]));
    assert_eq!(s.quorum(), 1);
    fold(
        &mut s,
        &[
            AggregationEvent::Merge { robot: 0 },
            AggregationEvent::Upload {
                robot: 0,
                samples: 2,
                weights: model(&[6, 8]),
            },
        ],
    );
    assert_eq!(&s.preview(1).weights[..], &[6, 8]);
    assert_eq!(s.preview(1).round, 1);
    assert_eq!(s.aggregations.len(), 1);
    // The upload is robot 0's first entry; the download was of the genesis model.
    let up = Entry::new(EntryId { key: 0, clock: 1 }, 2, model(&[6, 8])).bytes;
    let down = Entry::new(EntryId { key: 0, clock: 0 }, 1, model(&[0, 0])).bytes;
    assert_eq!((s.bytes_sent[0], s.bytes_downloaded[0]), (up, down));
    assert_eq!(s.bytes_sent[1], 0);
}

#[test]
fn a_byzantine_robot_reads_the_models_its_replica_or_the_server_holds() {
    let c = config(Aggregation::Gossip, 15);
    let params = crate::contract::ContractParams::from_config(&c, model(&[0, 0]));
    let mut s = AggregationState::new(&c, model(&[0, 0]));
    fold(
        &mut s,
        &[
            write(0, 1, &[10, -10]),
            write(1, 3, &[2, 2]),
            write(2, 5, &[7, 7]),
            AggregationEvent::Send {
                from: 1,
                to: 0,
                entries: vec![EntryId { key: 1, clock: 1 }],
                lost: false,
            },
            AggregationEvent::Deliver { message: 0 },
        ],
    );
    // Robot 0 holds its own entry and robot 1's, not robot 2's: it reads robot 1's only.
    let view = s.attacker_view(0, &params);
    let read: Vec<(u32, u64, i64)> = view
        .submissions
        .iter()
        .map(|x| (x.sender, x.samples, x.weights[0]))
        .collect();
    assert_eq!(read, vec![(1, 3, 2)]);
    assert_eq!(view.submissions[0].distance_units, 4, "|2 - 0| + |2 - 0|");
    assert_eq!(&view.weights[..], &s.current(0).weights[..]);

    let c = config(Aggregation::Central, 15);
    let mut s = AggregationState::new(&c, model(&[0, 0]));
    let params = crate::contract::ContractParams::from_config(&c, model(&[0, 0]));
    fold(
        &mut s,
        &[
            AggregationEvent::Upload {
                robot: 3,
                samples: 2,
                weights: model(&[6, 8]),
            },
            AggregationEvent::Upload {
                robot: 5,
                samples: 1,
                weights: model(&[1, 1]),
            },
        ],
    );
    // The open round's uploads of the others (the omniscient attacker).
    let view = s.attacker_view(5, &params);
    let senders: Vec<u32> = view.submissions.iter().map(|x| x.sender).collect();
    assert_eq!(senders, vec![3]);
    assert_eq!(view.round, 0);
}

#[test]
fn what_needs_a_chain_is_refused_naming_the_key() {
    fn refused(sets: &[&str]) -> String {
        let mut c = Preset::Smoke.config();
        for s in sets {
            c.set(s).unwrap();
        }
        c.validate().unwrap_err().to_string()
    }
    for (sets, key) in [
        (
            &["byzantine.ledger=equivocate", "byzantine.count=2"][..],
            "byzantine.ledger",
        ),
        (&["contract.rule=krum"][..], "contract.rule"),
        (&["contract.engine=evm"][..], "contract.engine"),
        (
            &["contract.round_timeout_s=300"][..],
            "contract.round_timeout_s",
        ),
        (
            &["faults.crashes=[{robot=3, start_s=50, end_s=120}]"][..],
            "faults.crashes",
        ),
        (
            &["faults.partitions=[{kind=\"sealer\", start_s=50, end_s=120}]"][..],
            "faults.partitions[0].kind",
        ),
    ] {
        for aggregation in ["gossip", "central"] {
            let mut all = vec![format!("learn.aggregation={aggregation}")];
            all.extend(sets.iter().map(|s| s.to_string()));
            let all: Vec<&str> = all.iter().map(String::as_str).collect();
            let e = refused(&all);
            assert!(
                e.contains(key) && e.contains("learn.aggregation = chain"),
                "{aggregation} {sets:?}: {e}"
            );
        }
        // The chain accepts them (evm with the default rule, krum with its default f); a build
        // without the evm feature refuses the engine, naming the feature instead.
        let mut c = Preset::Smoke.config();
        for s in sets {
            c.set(s).unwrap();
        }
        match c.validate() {
            Err(e) if !cfg!(feature = "evm") && key == "contract.engine" => {
                assert!(
                    e.to_string().contains("--features evm"),
                    "chain {sets:?}: {e}"
                );
            }
            got => assert!(got.is_ok(), "chain {sets:?}: {got:?}"),
        }
    }
    // Partitions that cut the radio, the paper's rule and byzantine.kind attacks run.
    let mut c = Preset::Smoke.config();
    for s in [
        "learn.aggregation=gossip",
        "faults.partitions=[{kind=\"split\", start_s=100, end_s=400}]",
        "byzantine.kind=alie",
        "byzantine.count=3",
    ] {
        c.set(s).unwrap();
    }
    c.validate().unwrap();
}

#[test]
fn the_ideal_server_is_off_the_radio_so_a_partition_changes_no_record() {
    let mut c = Preset::Smoke.config();
    c.run.duration_s = 150.0;
    c.learn.aggregation = Aggregation::Central;
    let mut cut = c.clone();
    cut.set("faults.partitions=[{kind=\"split\", start_s=0, end_s=150}]")
        .unwrap();
    cut.validate().unwrap();
    let plain: Vec<crate::event::Record> = crate::sim::Sim::new(c, 2).unwrap().collect();
    let parted: Vec<crate::event::Record> = crate::sim::Sim::new(cut, 2).unwrap().collect();
    assert!(plain.iter().any(|r| r.kind() == "upload"), "robots upload");
    assert_eq!(plain, parted);
}

#[test]
fn the_matched_ideal_refuses_the_rounds_and_a_buffer_above_the_swarm_naming_the_key() {
    let refused = |sets: &[&str]| {
        let mut c = Preset::Smoke.config();
        for s in sets {
            c.set(s).unwrap();
        }
        c.validate().unwrap_err().to_string()
    };
    let e = refused(&["learn.aggregation=matched"]);
    assert!(
        e.contains("learn.aggregation") && e.contains("contract.protocol = buffered"),
        "{e}"
    );
    let e = refused(&[
        "learn.aggregation=matched",
        "contract.protocol=buffered",
        "contract.buffer_size=16",
    ]);
    assert!(
        e.contains("contract.buffer_size") && e.contains("matched") && e.contains("15"),
        "{e}"
    );
    let mut ok = Preset::Smoke.config();
    ok.set("learn.aggregation=matched").unwrap();
    ok.set("contract.protocol=buffered").unwrap();
    ok.validate().unwrap();
}

#[test]
fn a_matched_run_steps_every_k_uploads_and_its_log_folds_to_the_same_server() {
    let mut c = Preset::Smoke.config();
    c.run.duration_s = 300.0;
    c.learn.aggregation = Aggregation::Matched;
    c.contract.protocol = crate::config::RoundProtocol::Buffered;
    c.validate().unwrap();
    let records: Vec<crate::event::Record> = crate::sim::Sim::new(c.clone(), 3).unwrap().collect();
    let again: Vec<crate::event::Record> = crate::sim::Sim::new(c.clone(), 3).unwrap().collect();
    assert_eq!(records, again);
    let genesis = crate::state::genesis_weights(&c, 3).unwrap();
    let mut s = AggregationState::new(&c, genesis);
    let mut uploads = 0;
    for r in &records {
        if let crate::event::Record::Event {
            time,
            event: crate::event::Event::Aggregation(e),
        } = r
        {
            uploads += u64::from(matches!(e, AggregationEvent::Upload { .. }));
            s.apply(*time, e).unwrap();
        }
    }
    assert!(uploads >= 14, "15 robots train in 300 s: {uploads} uploads");
    assert_eq!(s.matched.version, uploads / 7, "a step every K = 7 uploads");
    assert_eq!(s.aggregations.len() as u64, uploads / 7);
    assert_eq!(s.current(4).round, s.matched.version);
}

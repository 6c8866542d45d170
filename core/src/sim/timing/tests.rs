//! The timing models: the authors' Byzantine robots in step, their honest robots served one at
//! a time in arrival order, slots that do not depend on the order they are asked for, and the
//! independent model's phases as they always were.

use super::*;
use crate::rng::{self, Purpose};

const PERIOD: u64 = 100_000;
const JITTER: u64 = 1_000;
const SERVICE: u64 = 1_500;

/// 15 robots, 0, 3, 7, 8 and 12 Byzantine.
fn byzantine() -> Vec<bool> {
    (0..15).map(|r| [0, 3, 7, 8, 12].contains(&r)).collect()
}

fn setup(byzantine: &[bool]) -> Setup<'_> {
    Setup {
        seed: 11,
        byzantine,
        period_ms: PERIOD,
        duration_ms: 0,
        jitter_ms: JITTER,
        service_ms: SERVICE,
        kept: None,
    }
}

/// Every robot's first `phases` slots, asked robot by robot.
fn slots(model: &mut dyn TimingModel, robots: u32, phases: u64) -> Vec<Vec<Slot>> {
    (0..robots)
        .map(|r| (0..phases).map(|p| model.slot(r, p)).collect())
        .collect()
}

#[test]
fn the_authors_byzantine_robots_fire_within_the_jitter_of_each_other_every_cycle() {
    let byz = byzantine();
    let mut model = model(Timing::Authors, &setup(&byz));
    let all = slots(model.as_mut(), 15, 30);
    for cycle in 1..=30u64 {
        let phase = (cycle - 1) as usize;
        let times: Vec<u64> = (0..15)
            .filter(|&r| byz[r])
            .map(|r| all[r][phase])
            .map(|s| {
                assert_eq!(s.begin_ms, s.ready_ms, "a Byzantine robot does not train");
                s.begin_ms
            })
            .collect();
        let (lo, hi) = (*times.iter().min().unwrap(), *times.iter().max().unwrap());
        assert!(
            lo >= cycle * PERIOD && hi < cycle * PERIOD + JITTER,
            "cycle {cycle}: {times:?}"
        );
        assert!(hi - lo < JITTER);
    }
    assert!(model.submits_blind());
}

#[test]
fn the_authors_honest_robots_are_served_one_at_a_time_in_arrival_order() {
    let byz = byzantine();
    let mut model = model(Timing::Authors, &setup(&byz));
    let all = slots(model.as_mut(), 15, 12);
    // Every honest service, with the robot's arrival: its timer's first firing, then a
    // period after its previous training returned (end to start).
    let mut served: Vec<(Slot, u64, usize)> = Vec::new();
    for r in (0..15).filter(|&r| !byz[r]) {
        for (p, s) in all[r].iter().enumerate() {
            let arrival = if p == 0 {
                let jitter = rng::substream(11, Purpose::Timing, r as u32, 1).below(JITTER);
                PERIOD + jitter
            } else {
                all[r][p - 1].ready_ms + PERIOD
            };
            assert_eq!(s.ready_ms - s.begin_ms, SERVICE, "robot {r} phase {p}");
            assert!(
                s.begin_ms >= arrival,
                "served before it arrived: robot {r} phase {p}"
            );
            served.push((*s, arrival, r));
        }
    }
    served.sort_by_key(|(s, _, _)| s.begin_ms);
    for pair in served.windows(2) {
        let ((a, arrived_a, ra), (b, arrived_b, rb)) = (pair[0], pair[1]);
        assert!(
            b.begin_ms >= a.ready_ms,
            "two at once: robots {ra} and {rb}"
        );
        assert!(
            (arrived_a, ra) < (arrived_b, rb),
            "served out of arrival order: {ra} {rb}"
        );
        // Work-conserving: the server idles only while nobody waits.
        assert!(b.begin_ms == a.ready_ms || b.begin_ms == arrived_b);
    }
    // The first cycle's honest robots all arrive within the jitter and queue: the last of
    // the ten waits about nine services.
    let first: Vec<u64> = (0..15)
        .filter(|&r| !byz[r])
        .map(|r| all[r][0].begin_ms)
        .collect();
    let spread = first.iter().max().unwrap() - first.iter().min().unwrap();
    assert!(spread >= 9 * SERVICE - JITTER, "spread {spread}");
}

#[test]
fn slots_do_not_depend_on_the_order_they_are_asked_for() {
    let byz = byzantine();
    let forward = slots(model(Timing::Authors, &setup(&byz)).as_mut(), 15, 10);
    let mut backward_model = model(Timing::Authors, &setup(&byz));
    let mut backward = vec![Vec::new(); 15];
    for p in 0..10 {
        for r in (0..15).rev() {
            backward[r as usize].push(backward_model.slot(r, p));
        }
    }
    assert_eq!(forward, backward);
    // And forgetting the phases behind keeps the ones ahead.
    let mut m = model(Timing::Authors, &setup(&byz));
    for p in 0..10 {
        for r in 0..15 {
            assert_eq!(m.slot(r, p), forward[r as usize][p as usize]);
            m.forget(r, p + 1);
        }
    }
}

#[test]
fn the_independent_model_is_the_schedule_runs_always_had() {
    let byz = byzantine();
    let mut s = setup(&byz);
    s.duration_ms = 2_000;
    let mut model = model(Timing::Independent, &s);
    assert!(!model.submits_blind());
    for r in 0..15 {
        let phase0 = rng::stream(11, Purpose::Schedule, r).below(PERIOD);
        for p in 0..5 {
            let slot = model.slot(r, p);
            assert_eq!(slot.begin_ms, phase0 + p * PERIOD);
            assert_eq!(slot.ready_ms, slot.begin_ms + 2_000);
        }
    }
}

#[test]
fn a_reconfiguration_keeps_each_robots_next_phase() {
    let byz = byzantine();
    let mut old = model(Timing::Authors, &setup(&byz));
    let kept: Vec<(u64, Slot)> = (0..15).map(|r| (3, old.slot(r, 3))).collect();
    let mut s = setup(&byz);
    s.period_ms = 50_000;
    s.kept = Some(&kept);
    let mut new = model(Timing::Authors, &s);
    for r in 0..15u32 {
        assert_eq!(new.slot(r, 3), kept[r as usize].1);
        let next = new.slot(r, 4);
        assert!(next.begin_ms > kept[r as usize].1.begin_ms, "robot {r}");
        if byz[r as usize] {
            assert_eq!(
                next.begin_ms / 50_000,
                kept[r as usize].1.begin_ms / 50_000 + 1
            );
        } else {
            assert!(next.begin_ms >= kept[r as usize].1.ready_ms + 50_000);
        }
    }
}

//! Hand-computed buffers of the buffered protocol: the staleness weights, the sample- and
//! staleness-weighted mean update with the server step and its rounding, the refusals, the
//! judgement against the base, the deadline's refund and token conservation.

use std::sync::Arc;

use super::*;
use crate::contract::test_support::{STAKE, TOKEN};
use crate::contract::{Call, ContractParams, ContractState, Outcome};
use crate::types::Digest;

const ROBOTS: u32 = 10;

/// 10 robots with 21 tokens, stake 5, K accepted updates per version, the paper's rule with
/// a threshold of 100 units per weight (a 2-weight model may be 200 units from its base),
/// FedAsync's a = 0.5 and server step `step_units`.
fn params(k: u32, max_staleness: u32, step_units: u64) -> ContractParams {
    let mut reward_weights = vec![1; k as usize];
    if k > 1 {
        reward_weights[k as usize - 1] = -1;
    }
    ContractParams {
        outlier_threshold_units: 100,
        buffered: Some(BufferedParams {
            max_staleness,
            staleness_weights: (0..=max_staleness)
                .map(|t| staleness_weight(0.5, t))
                .collect(),
            step_units,
        }),
        ..crate::contract::test_support::params(ROBOTS, reward_weights, 2)
    }
}

/// The digest of the version `round` of `s`'s chain (the current one or a kept one).
fn digest_of(s: &ContractState, round: u64) -> Digest {
    let b = s.buffered.as_ref().unwrap();
    s.version(b, round).map(|(d, _)| d).unwrap()
}

fn update(
    s: &mut ContractState,
    p: &ContractParams,
    robot: u32,
    base: u64,
    w: [i64; 2],
    n: u64,
) -> Outcome {
    let call = Call::SubmitUpdate {
        weights: Arc::from(w.to_vec()),
        samples: n,
        base_round: base,
        base_digest: digest_of(s, base),
    };
    s.execute(p, robot, STAKE, &call)
}

#[test]
fn staleness_weights_are_fedasync_in_fixed_point() {
    // 2^16 * (1 + tau)^-0.5, rounded: 65536, 65536 / sqrt 2 = 46340.95, / sqrt 3 = 37837.23,
    // / 2, / sqrt 5 = 29308.98.
    let w: Vec<u64> = (0..5).map(|t| staleness_weight(0.5, t)).collect();
    assert_eq!(w, vec![65536, 46341, 37837, 32768, 29309]);
    // a = 0 weighs all alike; a steep exponent bottoms out at 1, never 0.
    assert_eq!(staleness_weight(0.0, 1000), 65536);
    assert_eq!(staleness_weight(10.0, 1000), 1);
}

#[test]
fn two_updates_of_different_staleness_and_samples_move_the_model_by_their_weighted_mean() {
    let p = params(2, 4, STEP_SCALE);
    let mut s = ContractState::genesis(&p);
    // Version 0 -> 1: two fresh updates of 1 sample each, [100, 0] and [200, 0]: mean 150.
    assert!(update(&mut s, &p, 0, 0, [100, 0], 1).is_accepted());
    assert!(matches!(
        update(&mut s, &p, 1, 0, [200, 0], 1),
        Outcome::Aggregated { round: 0, .. }
    ));
    assert_eq!(&s.weights[..], &[150, 0]);
    // Version 1: robot 2 trained from version 1 ([150, 0]) on 2 samples, update [150, 7].
    // Robot 3 trained from version 0 ([0, 0]) on 1 sample, update [-30, -4], staleness 1.
    assert!(update(&mut s, &p, 2, 1, [300, 7], 2).is_accepted());
    assert!(matches!(
        update(&mut s, &p, 3, 0, [-30, -4], 1),
        Outcome::Aggregated { round: 1, .. }
    ));
    // U_0 = (2 * 65536 * 150 + 46341 * -30) / (2 * 65536 + 46341) = 18270570 / 177413
    //     = 102.98 -> 103; U_1 = (2 * 65536 * 7 + 46341 * -4) / 177413 = 732140 / 177413
    //     = 4.13 -> 4.
    assert_eq!(&s.weights[..], &[150 + 103, 4]);
    assert_eq!(s.round, 2);
    assert_eq!(s.total_units(), p.total_units());
}

#[test]
fn three_updates_with_a_half_step_round_half_away_from_zero() {
    let p = params(3, 4, STEP_SCALE / 2);
    let mut s = ContractState::genesis(&p);
    // Version 0 -> 1: three updates [100, 100]: v1 = 0 + 100 / 2 = [50, 50].
    for r in 0..3 {
        update(&mut s, &p, r, 0, [100, 100], 1);
    }
    assert_eq!(&s.weights[..], &[50, 50]);
    // Version 1 -> 2: three updates [80, 80] from v1: v2 = 50 + 40 = [90, 90].
    for r in 3..6 {
        update(&mut s, &p, r, 1, [130, 130], 1);
    }
    assert_eq!(&s.weights[..], &[90, 90]);
    // Version 2: updates [90, -10] (3 samples, fresh), [-30, 50] (1 sample, base 1,
    // staleness 1), [60, 1] (2 samples, base 0, staleness 2).
    assert!(update(&mut s, &p, 6, 2, [180, 80], 3).is_accepted());
    assert!(update(&mut s, &p, 7, 1, [20, 100], 1).is_accepted());
    let before: Vec<u64> = s.balances.clone();
    let Outcome::Aggregated { payouts, .. } = update(&mut s, &p, 8, 0, [60, 1], 2) else {
        panic!("the third update closes the buffer");
    };
    // U_0 = (3 * 65536 * 90 + 46341 * -30 + 2 * 37837 * 60) / (3 * 65536 + 46341 + 2 * 37837)
    //     = 20844930 / 318623 = 65.42 -> 65, times 1/2 = 32.5 -> 33 (half away from zero);
    // U_1 = (3 * 65536 * -10 + 46341 * 50 + 2 * 37837 * 1) / 318623 = 426644 / 318623
    //     = 1.34 -> 1, times 1/2 = 0.5 -> 1.
    assert_eq!(&s.weights[..], &[90 + 33, 90 + 1]);
    // Ranked by |d - median d| on the distances to their bases: 100, 80, 61 -> median 80:
    // robot 7 (0), robot 8 (19), robot 6 (20, the penalised rank).
    let order: Vec<u32> = payouts.iter().map(|p| p.robot).collect();
    assert_eq!(order, vec![7, 8, 6]);
    assert_eq!(
        payouts.iter().map(|p| p.reward_weight).collect::<Vec<_>>(),
        vec![1, 1, -1]
    );
    // Robot 8 staked in this call: its balance moved by its payout minus its stake.
    assert_eq!(
        s.balances[8] + STAKE,
        before[8] + payouts.iter().find(|p| p.robot == 8).unwrap().units
    );
    assert_eq!(s.total_units(), p.total_units());
    // The history keeps versions 0, 1, 2 behind the newest (3).
    assert_eq!(s.buffered.as_ref().unwrap().history.len(), 3);
}

#[test]
fn a_submission_is_judged_against_its_base_and_bad_bases_are_refused_without_a_stake() {
    let p = params(1, 2, STEP_SCALE);
    let mut s = ContractState::genesis(&p);
    update(&mut s, &p, 0, 0, [150, 0], 1); // v1 = [150, 0]
    update(&mut s, &p, 1, 1, [300, 0], 1); // v2 = [300, 0]
    assert_eq!(&s.weights[..], &[300, 0]);
    // 100 from its base (version 0) but 400 from the newest: accepted (the paper's rounds
    // would call it an outlier).
    let Outcome::Aggregated { distance_units, .. } = update(&mut s, &p, 2, 0, [-100, 0], 1) else {
        panic!("accepted against its base");
    };
    assert_eq!(distance_units, 100);
    // v3 = [300 - 100] = [200, 0]. Version 0 is now 3 behind: stale (max 2).
    let balances = s.balances.clone();
    let call = |base_round: u64, base_digest: Digest| Call::SubmitUpdate {
        weights: vec![0, 0].into(),
        samples: 1,
        base_round,
        base_digest,
    };
    let genesis_digest = crate::contract::model_digest(&[0, 0]);
    let out = s.execute(&p, 3, STAKE, &call(0, genesis_digest));
    assert_eq!(out.name(), "stale");
    assert!(matches!(
        out,
        Outcome::Refused(Refusal::Stale {
            base_round: 0,
            round: 3,
            max_staleness: 2
        })
    ));
    // A version from the future, and a known version with another digest.
    let out = s.execute(&p, 3, STAKE, &call(7, genesis_digest));
    assert!(matches!(
        out,
        Outcome::Refused(Refusal::FutureBase {
            base_round: 7,
            round: 3
        })
    ));
    let out = s.execute(&p, 3, STAKE, &call(2, genesis_digest));
    assert!(matches!(
        out,
        Outcome::Refused(Refusal::UnknownBase { base_round: 2 })
    ));
    // Robot 2 counted against base 0; base 3 is newer, fine; then base 3 again is a duplicate.
    assert!(update(&mut s, &p, 2, 3, [250, 0], 1).is_accepted());
    let balances_after = s.balances.clone();
    let out = update(&mut s, &p, 2, 3, [250, 0], 1);
    assert!(matches!(
        out,
        Outcome::Refused(Refusal::DuplicateBase {
            base_round: 3,
            last_base: 3
        })
    ));
    let Outcome::Refused(refusal) = &out else {
        unreachable!()
    };
    assert!(refusal
        .reason()
        .contains("already counted against base version 3"));
    assert_eq!(s.balances, balances_after, "a refusal takes no stake");
    assert_eq!(balances[3], s.balances[3]);
    assert_eq!(s.buffered.as_ref().unwrap().refused, [1, 1, 1, 1]);
    // An outlier against its base: 250 > 200. Its stake stays in the pool.
    let v = s.round;
    let cur = s.weights.clone();
    let out = update(&mut s, &p, 4, v, [cur[0] + 250, cur[1]], 1);
    assert!(matches!(
        out,
        Outcome::Outlier {
            distance_units: 250,
            ..
        }
    ));
    // The paper's submitModel is malformed under this protocol, and submitUpdate under rounds.
    let model = Call::SubmitModel {
        weights: vec![0, 0].into(),
        samples: 1,
    };
    assert_eq!(s.execute(&p, 5, STAKE, &model).name(), "malformed");
    let rounds = ContractParams {
        buffered: None,
        rule_plugin: None,
        outlier: None,
        ..p.clone()
    };
    let mut r = ContractState::genesis(&rounds);
    assert_eq!(
        r.execute(&rounds, 5, STAKE, &call(0, genesis_digest))
            .name(),
        "malformed"
    );
    assert_eq!(s.total_units(), p.total_units());
}

#[test]
fn a_robot_has_submitted_once_it_counted_against_the_newest_version() {
    let p = params(3, 4, STEP_SCALE);
    let mut s = ContractState::genesis(&p);
    assert!(!s.has_submitted(0));
    update(&mut s, &p, 0, 0, [10, 0], 1);
    assert!(s.has_submitted(0));
    assert!(!s.has_submitted(1));
}

#[test]
fn a_deadline_refunds_the_buffer_and_lets_its_robots_submit_against_the_same_base() {
    let p = ContractParams {
        round_timeout_ms: 1_000,
        ..params(3, 4, STEP_SCALE)
    };
    let mut s = ContractState::genesis(&p);
    s.enter_block(&p, 10);
    update(&mut s, &p, 0, 0, [10, 0], 1);
    assert_eq!(s.balances[0], 16 * TOKEN);
    s.enter_block(&p, 2_000);
    assert_eq!(s.balances[0], 21 * TOKEN, "the accepted stake came back");
    assert!(!s.has_submitted(0));
    assert!(update(&mut s, &p, 0, 0, [10, 0], 1).is_accepted());
    // A restart (reconfiguration) refunds too, and forgets the base.
    s.restart_round();
    assert!(update(&mut s, &p, 0, 0, [10, 0], 1).is_accepted());
    assert_eq!(s.total_units(), p.total_units());
}

fn config_error(sets: &[&str]) -> String {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    match crate::config::Config::resolve(None, None, &sets) {
        Ok(_) => panic!("{sets:?} should be refused"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn absurd_buffer_and_staleness_settings_are_refused_naming_the_key_and_the_fix() {
    let b = "contract.protocol=buffered";
    let err = config_error(&[b, "contract.buffer_size=0"]);
    assert!(
        err.contains("contract.buffer_size") && err.contains("set contract.buffer_size"),
        "{err}"
    );
    // The paper's 15 robots: a buffer of 16 would need a robot twice per version.
    let err = config_error(&[b, "contract.buffer_size=16"]);
    assert!(err.contains("world.robots = 15"), "{err}");
    // Under the paper's rounds the buffer is unused: a swarm smaller than the default K runs
    // (the smoke sweeps of 4 and 6 robots), and buffered with the same swarm is refused.
    let small = "world.robots=4";
    assert!(crate::config::Config::resolve(None, None, &[small.to_string()]).is_ok());
    let err = config_error(&[b, small]);
    assert!(err.contains("world.robots = 4"), "{err}");
    let err = config_error(&[b, "contract.max_staleness=100000"]);
    assert!(
        err.contains("contract.max_staleness") && err.contains("at most 1000"),
        "{err}"
    );
    // Checked under rounds too, so a typo waits for nobody.
    let err = config_error(&["contract.max_staleness=4294967295"]);
    assert!(err.contains("contract.max_staleness"), "{err}");
    for bad in ["-1", "11", "nan"] {
        let err = config_error(&[b, &format!("contract.staleness_exponent={bad}")]);
        assert!(err.contains("contract.staleness_exponent"), "{err}");
    }
    for bad in ["0", "-1", "10.5", "inf"] {
        let err = config_error(&[b, &format!("contract.server_step={bad}")]);
        assert!(err.contains("contract.server_step"), "{err}");
    }
    let err = config_error(&[b, "learn.aggregation=gossip"]);
    assert!(
        err.contains("contract.protocol") && err.contains("learn.aggregation = chain"),
        "{err}"
    );
    let err = config_error(&[b, "contract.protocol=bufered"]);
    assert!(
        err.contains("unknown value `bufered`") && err.contains("`buffered`"),
        "{err}"
    );
    // A valid buffered configuration resolves, with K as its quorum.
    let sets: Vec<String> = [b, "contract.buffer_size=5", "contract.max_staleness=0"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let config = crate::config::Config::resolve(None, None, &sets).unwrap();
    assert_eq!(config.quorum(), 5);
    let params = ContractParams::from_config(&config, vec![0i64; 4].into());
    assert_eq!(
        params.buffered.unwrap().staleness_weights,
        vec![STALENESS_SCALE]
    );
}

#[cfg(feature = "evm")]
#[test]
fn the_evm_engine_refuses_the_buffered_protocol() {
    let err = config_error(&["contract.protocol=buffered", "contract.engine=evm"]);
    assert!(
        err.contains("contract.protocol") && err.contains("contract.engine = native"),
        "{err}"
    );
}

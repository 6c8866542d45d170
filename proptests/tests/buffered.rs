//! Property tests of the buffered protocol (`contract.protocol = "buffered"`) over random
//! transaction sequences: random bases (fresh, stale, beyond the bound, from the future, with
//! a wrong digest), hostile submissions (extreme weights, bad claims, wrong stakes, unknown
//! senders), deadlines and restarts. After every call: tokens are conserved exactly, no
//! balance leaves the supply (no underflow), a refused or failed call moves no token, a
//! refusal names a base that deserves it, a valid base within the bound is never refused,
//! the buffer never exceeds K and the version moves exactly when a buffer closes. Under the
//! relative outlier rule (`contract.outlier_rule = "relative"`, random factor, window and
//! cap): the bound stays between the floor and the cap, an accepted model is within the bound
//! in force when it arrived and an outlier beyond it, and the window never exceeds W x K.

use std::sync::Arc;

use proptest::prelude::*;
use swarmfl_core::config::Rule;
use swarmfl_core::contract::buffered::{staleness_weight, BufferedParams, Refusal};
use swarmfl_core::contract::outlier::RelativeOutlier;
use swarmfl_core::contract::{Call, ContractParams, ContractState, Outcome};
use swarmfl_core::types::Digest;
use swarmfl_core::RobotId;

mod common;
use common::{base_params, robust, INT48, STAKE};

const ROBOTS: u32 = 6;
const MAX_STALENESS: u32 = 3;

fn params(rule: Rule, timeout_ms: u64, outlier: Option<RelativeOutlier>) -> ContractParams {
    ContractParams {
        security: rule != Rule::Fedavg,
        robust: robust(rule),
        round_timeout_ms: timeout_ms,
        buffered: Some(BufferedParams {
            max_staleness: MAX_STALENESS,
            staleness_weights: (0..=MAX_STALENESS)
                .map(|t| staleness_weight(0.5, t))
                .collect(),
            step_units: 1_000_000,
        }),
        outlier,
        ..base_params(ROBOTS, vec![1, 1, -1])
    }
}

/// One step of a sequence.
#[derive(Clone, Debug)]
enum Step {
    /// A submission whose base is `back` versions behind the newest (negative: ahead), with
    /// the right digest unless `wrong_digest`; its weights are the base plus `deltas`, or
    /// `raw` when given (hostile).
    Update {
        sender: RobotId,
        value_units: u64,
        back: i64,
        wrong_digest: bool,
        deltas: Vec<i64>,
        raw: Option<Vec<i64>>,
        samples: u64,
    },
    /// The paper's call, malformed under this protocol.
    Model { sender: RobotId },
    /// A block `advance_ms` after the last one.
    Block { advance_ms: u64 },
    /// A reconfiguration restarts the buffer.
    Restart,
}

fn step() -> impl Strategy<Value = Step> {
    let sender = prop_oneof![12 => 0..ROBOTS, 1 => ROBOTS..ROBOTS + 3];
    let value =
        prop_oneof![20 => Just(STAKE), 1 => Just(0u64), 1 => Just(STAKE + 1), 1 => any::<u64>()];
    let back = prop_oneof![10 => 0i64..=1, 4 => 2i64..=i64::from(MAX_STALENESS + 2), 1 => -3i64..0];
    let delta = prop_oneof![30 => -40_000_000i64..40_000_000, 1 => any::<i64>()];
    let deltas = proptest::collection::vec(delta, 3);
    let raw_weight = prop_oneof![
        Just(INT48 - 1),
        Just(-(INT48 - 1)),
        Just(INT48),
        any::<i64>()
    ];
    let raw = prop_oneof![
        20 => Just(None),
        1 => proptest::collection::vec(raw_weight, 3).prop_map(Some),
        1 => proptest::collection::vec(-10i64..10, 0..5).prop_map(Some),
    ];
    let samples = prop_oneof![20 => 1u64..1000, 1 => Just(0u64), 1 => Just(u64::from(u32::MAX)), 1 => any::<u64>()];
    let update = (
        sender.clone(),
        value,
        back,
        any::<bool>(),
        deltas,
        raw,
        samples,
    )
        .prop_map(
            |(sender, value_units, back, wrong, deltas, raw, samples)| Step::Update {
                sender,
                value_units,
                back,
                // Mostly the right digest.
                wrong_digest: wrong && back % 3 == 0,
                deltas,
                raw,
                samples,
            },
        );
    prop_oneof![
        40 => update,
        1 => sender.prop_map(|sender| Step::Model { sender }),
        4 => (0u64..1500).prop_map(|advance_ms| Step::Block { advance_ms }),
        1 => Just(Step::Restart),
    ]
}

/// The digest and model of version `base` on `s`'s chain, if it keeps it.
fn version(s: &ContractState, base: u64) -> Option<(Digest, Arc<[i64]>)> {
    let behind = s.round.checked_sub(base)?;
    if behind == 0 {
        return Some((s.weights_digest, s.weights.clone()));
    }
    let history = &s.buffered.as_ref()?.history;
    let i = (history.len() as u64).checked_sub(behind)?;
    history.get(i as usize).map(|(d, w)| (*d, w.clone()))
}

fn run(
    rule: Rule,
    timeout_ms: u64,
    outlier: Option<RelativeOutlier>,
    steps: &[Step],
) -> Result<(), TestCaseError> {
    let p = params(rule, timeout_ms, outlier);
    let floor = u128::from(p.outlier_threshold_units as u64) * p.model_len() as u128;
    let mut s = ContractState::genesis(&p);
    let total = p.total_units();
    let mut now_ms = 0;
    for step in steps {
        let before = s.clone();
        match step {
            Step::Block { advance_ms } => {
                now_ms += advance_ms;
                s.enter_block(&p, now_ms);
            }
            Step::Restart => s.restart_round(),
            Step::Model { sender } => {
                let call = Call::SubmitModel {
                    weights: vec![0, 0, 0].into(),
                    samples: 1,
                };
                let out = s.execute(&p, *sender, STAKE, &call);
                prop_assert_eq!(out.name(), "malformed");
                prop_assert_eq!(&s.balances, &before.balances);
            }
            Step::Update {
                sender,
                value_units,
                back,
                wrong_digest,
                deltas,
                raw,
                samples,
            } => {
                let base_round = if *back >= 0 {
                    s.round.saturating_sub(*back as u64)
                } else {
                    s.round + back.unsigned_abs()
                };
                let kept = version(&s, base_round);
                let base_digest = match (&kept, wrong_digest) {
                    (Some((d, _)), false) => *d,
                    _ => Digest::of(b"not a version of this chain"),
                };
                let weights: Arc<[i64]> = match (raw, &kept) {
                    (Some(raw), _) => raw.clone().into(),
                    (None, Some((_, base))) => base
                        .iter()
                        .zip(deltas)
                        .map(|(&b, &d)| b.saturating_add(d))
                        .collect(),
                    (None, None) => deltas.clone().into(),
                };
                let call = Call::SubmitUpdate {
                    weights,
                    samples: *samples,
                    base_round,
                    base_digest,
                };
                let bound = s.outlier_bound_units(&p);
                let cap = outlier.map_or(floor, |o| u128::from(o.cap_units as u64) * 3);
                prop_assert!(floor <= bound && bound <= cap.max(floor), "{bound}");
                let out = s.execute(&p, *sender, *value_units, &call);
                // Only the paper's rule checks the bound on arrival.
                match &out {
                    Outcome::Accepted { distance_units, .. }
                    | Outcome::Aggregated { distance_units, .. }
                        if p.rule().uses_threshold() =>
                    {
                        prop_assert!(u128::from(*distance_units) <= bound)
                    }
                    Outcome::Outlier { distance_units, .. } => {
                        prop_assert!(u128::from(*distance_units) > bound)
                    }
                    _ => {}
                }
                let last_base = before
                    .buffered
                    .as_ref()
                    .and_then(|b| b.last_base.get(*sender as usize).copied());
                match &out {
                    Outcome::Refused(r) => {
                        prop_assert_eq!(&s.balances, &before.balances);
                        prop_assert_eq!(s.holdings_units, before.holdings_units);
                        prop_assert_eq!(s.round, before.round);
                        match r {
                            Refusal::FutureBase { .. } => prop_assert!(base_round > before.round),
                            Refusal::Stale { .. } => prop_assert!(
                                base_round < before.round
                                    && before.round - base_round > u64::from(MAX_STALENESS)
                            ),
                            Refusal::UnknownBase { .. } => {
                                prop_assert!(kept.as_ref().map(|k| k.0) != Some(base_digest))
                            }
                            Refusal::DuplicateBase { .. } => {
                                prop_assert!(last_base.unwrap() > base_round)
                            }
                        }
                    }
                    Outcome::Malformed(_) | Outcome::InsufficientStake => {
                        prop_assert_eq!(&s.balances, &before.balances);
                        prop_assert_eq!(s.holdings_units, before.holdings_units);
                    }
                    Outcome::Aggregated { round, .. } => {
                        prop_assert_eq!(*round, before.round);
                        prop_assert_eq!(s.round, before.round + 1);
                        prop_assert!(s.submissions.is_empty());
                    }
                    Outcome::Accepted { .. } | Outcome::Outlier { .. } => {
                        prop_assert_eq!(s.round, before.round);
                        prop_assert_eq!(s.submissions.len(), before.submissions.len() + 1);
                    }
                    other => prop_assert!(false, "unexpected outcome {other:?}"),
                }
                // A valid base within the bound, newer than the sender's last, is judged.
                let valid = (*sender as usize) < ROBOTS as usize
                    && kept.is_some()
                    && !wrong_digest
                    && last_base.is_some_and(|l| l <= base_round);
                if valid {
                    prop_assert!(!matches!(out, Outcome::Refused(_)), "{out:?}");
                }
            }
        }
        prop_assert_eq!(s.total_units(), total);
        prop_assert!(s.balances.iter().all(|&b| u128::from(b) <= total));
        prop_assert!(s.accepted_count() < p.quorum);
        let b = s.buffered.as_ref().unwrap();
        prop_assert_eq!(b.entries.len(), s.submissions.len());
        prop_assert!(b.history.len() <= MAX_STALENESS as usize);
        let window = outlier.map_or(0, |o| o.window_len(p.quorum));
        prop_assert!(b.outlier_window.len() <= window);
        prop_assert!(s.weights.iter().all(|w| w.unsigned_abs() < INT48 as u64));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn paper_rule_conserves_tokens_and_refuses_only_bad_bases(
        steps in proptest::collection::vec(step(), 1..200),
        timeout in prop_oneof![Just(0u64), 500u64..3000],
    ) {
        run(Rule::Paper, timeout, None, &steps)?;
    }

    #[test]
    fn relative_outlier_rule_conserves_tokens_and_keeps_its_bound(
        steps in proptest::collection::vec(step(), 1..200),
        timeout in prop_oneof![Just(0u64), 500u64..3000],
        factor_micro in prop_oneof![500_000u64..10_000_000, 1u64..=u64::from(u32::MAX)],
        window_buffers in 1u32..=4,
        cap_units in 50_000_000i64..200_000_000,
    ) {
        let outlier = RelativeOutlier { factor_micro, window_buffers, cap_units };
        run(Rule::Paper, timeout, Some(outlier), &steps)?;
    }

    #[test]
    fn robust_rules_and_fedavg_aggregate_updates_safely(
        steps in proptest::collection::vec(step(), 1..120),
        rule in prop_oneof![Just(Rule::Fedavg), Just(Rule::Median), Just(Rule::TrimmedMean), Just(Rule::CenteredClipping), Just(Rule::Monna)],
    ) {
        run(rule, 0, None, &steps)?;
    }
}

//! Hand-computed rounds through the chain and the rule, and one contract round with a chain.

use std::sync::Arc;

use super::*;
use crate::config::{ContractOptions, Preaggregator, Rule};
use crate::contract::rules::inputs_of;
use crate::contract::{Call, ContractParams, ContractState, Outcome, RobustRule};
use crate::types::RobotId;

fn chain(stages: &[Preaggregator], f: u32) -> PreaggParams {
    PreaggParams {
        stages: stages.to_vec(),
        assumed_f: f,
        bucket_size: 2,
        clip_radius_units: 5,
    }
}

#[test]
fn nnm_then_median_pays_the_raw_models_nearest_the_result() {
    // NNM with f = 1 (four neighbours): 0, 2, 4, 6 each become 12 / 4 = 3, 100 becomes
    // (100 + 6 + 4 + 2) / 4 = 28. The median of 3, 3, 3, 3, 28 is 3 (the raw median is 4).
    // Median uses q - f = 4 outputs of 5, so k = 4 raw models, nearest (L1) to 3:
    // distances 3, 1, 1, 3, 97 -> 1, 2, 0, 3.
    let inputs = inputs_of(&[(&[0], 1), (&[2], 1), (&[4], 1), (&[6], 1), (&[100], 1)]);
    let options = ContractOptions::default();
    let a = aggregate(
        Rule::Median,
        &chain(&[Preaggregator::Nnm], 1),
        &[0],
        &inputs,
        1,
        &options,
        [0; 32],
    );
    assert_eq!(a.weights, vec![3]);
    assert_eq!(a.used, vec![1, 2, 0, 3]);
    assert_eq!(
        Rule::Median.aggregate(&[0], &inputs, 1, &options).weights,
        vec![4]
    );
}

#[test]
fn bucketing_shrinks_the_round_and_scales_the_used_count_back() {
    // Six models, buckets of 2: three bucket means; median with f = 1 uses 2 of 3, so
    // k = ceil(2 * 6 / 3) = 4 raw models are paid.
    let models: [&[i64]; 6] = [&[0], &[10], &[20], &[30], &[40], &[1000]];
    let inputs = inputs_of(&models.map(|w| (w, 1u64)));
    let seed = [3; 32];
    let pi = bucketing::permutation(6, seed);
    let mut means: Vec<i64> = (0..3)
        .map(|b| (models[pi[2 * b]][0] + models[pi[2 * b + 1]][0] + 1) / 2)
        .collect();
    means.sort_unstable();
    let a = aggregate(
        Rule::Median,
        &chain(&[Preaggregator::Bucketing], 1),
        &[0],
        &inputs,
        1,
        &ContractOptions::default(),
        seed,
    );
    assert_eq!(a.weights, vec![means[1]]);
    assert_eq!(a.used, rules::nearest(&inputs, &a.weights, 4));
    assert_eq!(a.used.len(), 4);
}

#[test]
fn paper_keeps_its_ranking_of_the_submissions_and_averages_the_clipped() {
    // Clipping at radius 5 around 0: 3 -> 3, 4 -> 4, 50 -> 5; sample-weighted FedAvg with
    // samples 1, 1, 2: (3 + 4 + 10) / 4 = 4.25 -> 4. The ranking is the paper's on the raw
    // distances (50, 10, 30 -> median 30: |d - 30| = 20, 20, 0 -> 2, 0, 1).
    let models: [&[i64]; 3] = [&[3], &[4], &[50]];
    let inputs: Vec<Input> = models
        .iter()
        .zip([(1u64, 50u64), (1, 10), (2, 30)])
        .map(|(w, (samples, distance_units))| Input {
            weights: w,
            samples,
            distance_units,
        })
        .collect();
    let options = ContractOptions::default();
    let a = aggregate(
        Rule::Paper,
        &chain(&[Preaggregator::Clipping], 0),
        &[0],
        &inputs,
        0,
        &options,
        [0; 32],
    );
    assert_eq!(a.weights, vec![4]);
    assert_eq!(
        a.used,
        Rule::Paper.aggregate(&[0], &inputs, 0, &options).used
    );
    assert_eq!(a.used, vec![2, 0, 1]);
}

#[test]
fn stages_compose_in_list_order() {
    // ARC (f = 1, n = 4: k = 1) then NNM (f = 1): ARC clips 40 to the next norm, 3; NNM then
    // mixes 1, 2, 3, 3: each takes three neighbours. 1: {1, 2, 3(idx 2)} = 2; 2: {2, 1, 3} = 2;
    // 3 (idx 2): {3, 3, 2} = 8 / 3 -> 3; 3 (idx 3): {3, 3, 2} -> 3.
    let models = staged_of(&[&[1], &[2], &[3], &[40]]);
    let inputs: Vec<Input> = models
        .iter()
        .map(|m| Input {
            weights: &m.weights,
            samples: 1,
            distance_units: 0,
        })
        .collect();
    let out = run_chain(
        &chain(&[Preaggregator::Arc, Preaggregator::Nnm], 1),
        &[0],
        &inputs,
        [0; 32],
    );
    let w: Vec<i64> = out.iter().map(|s| s.weights[0]).collect();
    assert_eq!(w, vec![2, 2, 3, 3]);
    // The other order: NNM first mixes 40 into (40 + 3 + 2) / 3 = 15, then ARC clips 15 to 2.
    let out = run_chain(
        &chain(&[Preaggregator::Nnm, Preaggregator::Arc], 1),
        &[0],
        &inputs,
        [0; 32],
    );
    let w: Vec<i64> = out.iter().map(|s| s.weights[0]).collect();
    assert_eq!(w, vec![2, 2, 2, 2]);
}

#[test]
fn the_shuffle_seed_is_chain_data() {
    let d = Digest::of(b"m");
    let a = shuffle_seed(3, &d, &[(1, d), (2, d)]);
    assert_eq!(a, shuffle_seed(3, &d, &[(1, d), (2, d)]));
    assert_ne!(a, shuffle_seed(4, &d, &[(1, d), (2, d)]));
    assert_ne!(a, shuffle_seed(3, &d, &[(2, d), (1, d)]));
}

const TOKEN: u64 = 1_000_000_000;
const STAKE: u64 = 5 * TOKEN;

/// A contract round of median with NNM in front: seven robots, quorum 7, f = 2.
#[test]
fn a_contract_round_with_nnm_conserves_tokens_and_pays_the_nearest() {
    let p = ContractParams {
        robots: 7,
        initial_units: 21 * TOKEN,
        stake_units: STAKE,
        security: true,
        quorum: 7,
        outlier_threshold_units: 50_000_000,
        reward_weights: vec![1; 7],
        genesis_weights: vec![0i64; 4].into(),
        robust: Some(RobustRule {
            rule: Rule::Median,
            assumed_f: 2,
            threshold_gate: false,
        }),
        round_timeout_ms: 0,
        options: Default::default(),
        engine: Default::default(),
        defence: None,
        block_gas_limit: crate::config::AUTHORS_BLOCK_GAS_LIMIT,
        claim_bound: Default::default(),
        preagg: Some(chain(&[Preaggregator::Nnm], 2)),
        buffered: None,
        rule_plugin: None,
        outlier: None,
    };
    p.check().unwrap();
    let mut s = ContractState::genesis(&p);
    // First weights 10, 11, 2^40, 9, 12, 8, 13; NNM keeps five neighbours:
    // 10 -> {10, 11, 9, 12, 8} = 10; 11 -> {11, 10, 12, 9, 13} = 11;
    // 2^40 -> {2^40, 13, 12, 11, 10} = (2^40 + 46) / 5 -> 219902325564;
    // 9 -> {9, 10, 8, 11, 12} = 10; 12 -> {12, 11, 13, 10, 9} = 11;
    // 8 -> {8, 9, 10, 11, 12} = 10; 13 -> {13, 12, 11, 10, 9} = 11.
    // Median of 10, 11, big, 10, 11, 10, 11 = 11.
    let far = 1i64 << 40;
    let mut last = None;
    for (robot, v) in [10, 11, far, 9, 12, 8, 13].into_iter().enumerate() {
        let call = Call::SubmitModel {
            weights: Arc::from(vec![v, 0, 0, 0]),
            samples: 10,
        };
        last = Some(s.execute(&p, robot as RobotId, STAKE, &call));
    }
    let Some(Outcome::Aggregated { payouts, .. }) = last else {
        panic!("the seventh model aggregates: {last:?}");
    };
    assert_eq!(&s.weights[..], &[11, 0, 0, 0]);
    // Five paid, nearest (L1) to 11 among the raw submissions: 0, 1, 1, 2, 2 for robots
    // 1, 0, 4, 3, 6; robots 2 and 5 lose their stakes.
    let paid: Vec<RobotId> = payouts.iter().map(|p| p.robot).collect();
    assert_eq!(paid, vec![1, 0, 4, 3, 6]);
    assert!(payouts.iter().all(|p| p.units == 7 * TOKEN));
    assert_eq!(s.balances[2], 16 * TOKEN);
    assert_eq!(s.balances[5], 16 * TOKEN);
    assert_eq!(s.total_units(), p.total_units());
}

/// Parameters without a chain encode as before pre-aggregators existed; a chain is committed to.
#[test]
fn parameters_without_a_chain_encode_as_before() {
    let p = ContractParams {
        robots: 2,
        initial_units: 10,
        stake_units: 1,
        security: true,
        quorum: 1,
        outlier_threshold_units: 1,
        reward_weights: vec![1],
        genesis_weights: vec![0i64; 1].into(),
        robust: None,
        round_timeout_ms: 0,
        options: Default::default(),
        engine: Default::default(),
        defence: None,
        preagg: None,
        block_gas_limit: crate::config::AUTHORS_BLOCK_GAS_LIMIT,
        claim_bound: Default::default(),
        buffered: None,
        rule_plugin: None,
        outlier: None,
    };
    let q = ContractParams {
        block_gas_limit: crate::config::AUTHORS_BLOCK_GAS_LIMIT,
        claim_bound: Default::default(),
        preagg: Some(chain(&[Preaggregator::Bucketing], 0)),
        ..p.clone()
    };
    let a = rmp_serde::to_vec(&p).unwrap();
    let b = rmp_serde::to_vec(&q).unwrap();
    assert_eq!(&b[1..a.len()], &a[1..], "one more field at the end");
    assert_eq!(rmp_serde::from_slice::<ContractParams>(&a).unwrap(), p);
    // The encoding is a commitment (the genesis block's), never decoded: a chain changes it.
    assert!(b.len() > a.len());
}

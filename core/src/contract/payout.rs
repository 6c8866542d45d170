//! The contract's arithmetic as pure functions: distance, FedAvg, ranking, payouts. Integers
//! only; every rounding choice is stated where it is made.

/// `sum_i |a_i - b_i|`, the L1 distance in fixed-point units (the paper's mean distance times
/// N). The caller guarantees equal lengths, `|a_i|, |b_i| < 2^47` and `len <= 2^16`, so the
/// sum stays below 2^64.
pub fn distance_units(a: &[i64], b: &[i64]) -> u64 {
    assert_eq!(
        a.len(),
        b.len(),
        "distance between models of different lengths"
    );
    let sum: u128 = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| (i128::from(x) - i128::from(y)).unsigned_abs())
        .sum();
    u64::try_from(sum).expect("int48 weights and at most 2^16 of them keep distances in u64")
}

/// FedAvg: `w_i = sum_k n_k w_k,i / sum_k n_k`, computed exactly in `i128` and rounded to the
/// nearest integer, ties away from zero (symmetric, so the average of a model and its negation
/// stays centred). `models` is non-empty, all of one length, with `n_k >= 1`.
pub fn fedavg(models: &[(&[i64], u64)]) -> Vec<i64> {
    assert!(!models.is_empty(), "FedAvg of no models");
    let len = models[0].0.len();
    assert!(models.iter().all(|(w, n)| w.len() == len && *n >= 1));
    let total: i128 = models.iter().map(|&(_, n)| i128::from(n)).sum();
    (0..len)
        .map(|i| {
            let num: i128 = models
                .iter()
                .map(|&(w, n)| i128::from(n) * i128::from(w[i]))
                .sum();
            let w = div_round_half_away(num, total);
            i64::try_from(w).expect("a weighted mean lies within its inputs' range")
        })
        .collect()
}

/// `num / den` rounded to the nearest integer, ties away from zero; `den > 0`.
pub fn div_round_half_away(num: i128, den: i128) -> i128 {
    assert!(den > 0);
    let magnitude = (num.unsigned_abs() + den.unsigned_abs() / 2) / den.unsigned_abs();
    let magnitude = i128::try_from(magnitude).expect("quotient fits i128");
    if num < 0 {
        -magnitude
    } else {
        magnitude
    }
}

/// The ranking: indices of `distances` (in submission order), best first. The key is
/// `|d_k - median(d)|`, the median being the middle of the sorted distances (for an even count
/// the lower middle, `sorted[(q - 1) / 2]`); ties keep submission order (stable sort). So the
/// median model is ranked first, as in the paper.
pub fn rank(distances: &[u64]) -> Vec<usize> {
    assert!(!distances.is_empty(), "ranking of no models");
    let mut sorted = distances.to_vec();
    sorted.sort_unstable();
    let median = sorted[(sorted.len() - 1) / 2];
    let mut order: Vec<usize> = (0..distances.len()).collect();
    order.sort_by_key(|&i| distances[i].abs_diff(median));
    order
}

/// The payouts of a pool, in rank order. `ranked_samples[r]` is the samples claimed by the
/// model ranked `r`, `reward_weights[r]` its reward weight k. With `q` ranks and pool P:
/// - `k > 0` (group R): `floor(P / q) + floor(stake * k s / sum_R k_j s_j)`;
/// - `k < 0` (group P): `floor(P / q) - ceil(stake * |k| s / sum_P |k_j| s_j)`, saturating at 0;
/// - `k == 0`: `floor(P / q)`.
///
/// The bonus of group R is what group P gives up, so when no rank is penalised there is no
/// bonus (the rewarded get `floor(P / q)`): this keeps `sum(payouts) <= P` for every quorum.
/// With `P >= q * stake` (every ranked model staked) the saturation never triggers and the sum
/// is at most P; the caller keeps `P - sum` as the carried remainder. With `P = q * stake` and
/// ±1 weights this is the paper's `(1 ± k_i s_i / sum k_j s_j) * stake`, rounded.
pub fn payouts(
    pool_units: u64,
    stake_units: u64,
    ranked_samples: &[u64],
    reward_weights: &[i64],
) -> Vec<u64> {
    assert_eq!(
        ranked_samples.len(),
        reward_weights.len(),
        "one reward weight per rank"
    );
    assert!(!ranked_samples.is_empty());
    let q = ranked_samples.len() as u64;
    let base = pool_units / q;
    let weighted = |want_positive: bool| -> u128 {
        ranked_samples
            .iter()
            .zip(reward_weights)
            .filter(|(_, &k)| if want_positive { k > 0 } else { k < 0 })
            .map(|(&s, &k)| u128::from(k.unsigned_abs()) * u128::from(s))
            .sum()
    };
    let sum_rewarded = weighted(true);
    let sum_penalised = weighted(false);
    let stake = u128::from(stake_units);
    let out: Vec<u64> = ranked_samples
        .iter()
        .zip(reward_weights)
        .map(|(&s, &k)| {
            let share = u128::from(k.unsigned_abs()) * u128::from(s) * stake;
            if k > 0 && sum_penalised > 0 {
                let bonus = u64::try_from(share / sum_rewarded).expect("bonus <= stake");
                base.checked_add(bonus).expect("pool fits u64")
            } else if k < 0 {
                let penalty =
                    u64::try_from(share.div_ceil(sum_penalised)).expect("penalty <= stake");
                base.saturating_sub(penalty)
            } else {
                base
            }
        })
        .collect();
    let paid: u128 = out.iter().map(|&u| u128::from(u)).sum();
    assert!(
        paid <= u128::from(pool_units),
        "payouts {paid} exceed the pool {pool_units}"
    );
    out
}

/// The reward rule of the robust rules: each of the `used` submissions gets `floor(P / used)`
/// of the pool P (its stake back plus an equal share of the stakes of the submissions the rule
/// did not use and of the carried remainder); the rest stays in the contract. `used >= 1`.
pub fn equal_shares(pool_units: u64, used: usize) -> u64 {
    assert!(used >= 1, "a rule uses at least one submission");
    pool_units / used as u64
}

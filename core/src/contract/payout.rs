//! The contract's arithmetic as pure functions: distance, FedAvg, ranking, payouts. Integers
//! only; every rounding choice is stated where it is made. The authors' variants
//! ([`super::options`]) are arguments; their defaults are swarmfl's rules.

use crate::config::{FedAvgRounding, MedianRule, PayoutRounding, RankTies};

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
/// stays centered), or truncated toward zero with [`FedAvgRounding::Truncate`]. `models` is
/// non-empty, all of one length, with `n_k >= 1`.
pub fn fedavg(models: &[(&[i64], u64)], rounding: FedAvgRounding) -> Vec<i64> {
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
            let w = match rounding {
                FedAvgRounding::Nearest => div_round_half_away(num, total),
                FedAvgRounding::Truncate => num / total,
            };
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
/// `|d_k - median(d)|` ([`median`]); ties keep submission order (stable sort), or with
/// [`RankTies::Quicksort`] the order the authors' quicksort leaves ([`order_by`]). So the
/// median model is ranked first, as in the paper.
pub fn rank(distances: &[u64], median_rule: MedianRule, ties: RankTies) -> Vec<usize> {
    assert!(!distances.is_empty(), "ranking of no models");
    let centre = median(distances, median_rule);
    let keys: Vec<u64> = distances.iter().map(|d| d.abs_diff(centre)).collect();
    order_by(&keys, ties)
}

/// The median of `distances` (non-empty): the middle of the sorted distances, for an even
/// count the lower middle `sorted[(q - 1) / 2]`, or with [`MedianRule::Mean`] the floored
/// mean of the two middles.
pub fn median(distances: &[u64], median_rule: MedianRule) -> u64 {
    assert!(!distances.is_empty(), "median of no distances");
    let mut sorted = distances.to_vec();
    sorted.sort_unstable();
    let q = sorted.len();
    match median_rule {
        MedianRule::Lower => sorted[(q - 1) / 2],
        // Both middles are below 2^64, so their sum fits u128.
        MedianRule::Mean => {
            ((u128::from(sorted[q - 1 - q / 2]) + u128::from(sorted[q / 2])) / 2) as u64
        }
    }
}

/// Indices of `keys` sorted by ascending key: ties in submission order (stable), or with
/// [`RankTies::Quicksort`] in whatever order the authors' quicksort leaves.
pub fn order_by(keys: &[u64], ties: RankTies) -> Vec<usize> {
    let mut order: Vec<usize> = (0..keys.len()).collect();
    match ties {
        RankTies::Stable => order.sort_by_key(|&i| keys[i]),
        RankTies::Quicksort => {
            let last = keys.len() as i64 - 1;
            let mut keys = keys.to_vec();
            quicksort(&mut keys, &mut order, 0, last);
        }
    }
    order
}

/// The authors' Hoare quicksort of `keys` ascending, carrying `order` along (not stable:
/// equal keys end in whatever order the swaps leave), ported statement for statement.
fn quicksort(keys: &mut [u64], order: &mut [usize], left: i64, right: i64) {
    let (mut i, mut j) = (left, right);
    if i == j {
        return;
    }
    let pivot = keys[(left + (right - left) / 2) as usize];
    while i <= j {
        while keys[i as usize] < pivot {
            i += 1;
        }
        while pivot < keys[j as usize] {
            j -= 1;
        }
        if i <= j {
            keys.swap(i as usize, j as usize);
            order.swap(i as usize, j as usize);
            i += 1;
            j -= 1;
        }
    }
    if left < j {
        quicksort(keys, order, left, j);
    }
    if i < right {
        quicksort(keys, order, i, right);
    }
}

/// The authors' implicit int48 bound (`contract.int48_products`): the round's accepted models
/// so far are `accepted`; a new accepted model `weights` with `samples` must keep every
/// `w_i * n` and every running sum `sum_k n_k w_k,i + w_i * n` inside int48.
pub fn int48_products(
    accepted: &[(&[i64], u64)],
    weights: &[i64],
    samples: u64,
) -> Result<(), String> {
    const MIN: i128 = -(1 << 47);
    const MAX: i128 = (1 << 47) - 1;
    let n = i128::from(samples);
    for (i, &w) in weights.iter().enumerate() {
        let product = i128::from(w) * n;
        let sum: i128 = accepted
            .iter()
            .map(|&(m, k)| i128::from(m[i]) * i128::from(k))
            .sum::<i128>()
            + product;
        if !(MIN..=MAX).contains(&product) || (!accepted.is_empty() && !(MIN..=MAX).contains(&sum))
        {
            return Err(format!(
                "weight {i} = {w} times {samples} samples leaves int48 (contract.int48_products)"
            ));
        }
    }
    Ok(())
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
/// ±1 weights this is the paper's `(1 ± k_i s_i / sum k_j s_j) * stake`, rounded. With
/// [`PayoutRounding::Ratio1e9`] both shares are `floor(stake * floor(1e9 |k| s / sum) / 1e9)`.
pub fn payouts(
    pool_units: u64,
    stake_units: u64,
    ranked_samples: &[u64],
    reward_weights: &[i64],
    rounding: PayoutRounding,
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
            let ks = u128::from(k.unsigned_abs()) * u128::from(s);
            let share = |sum: u128, ceil: bool| -> u64 {
                let units = match rounding {
                    PayoutRounding::Exact if ceil => (ks * stake).div_ceil(sum),
                    PayoutRounding::Exact => ks * stake / sum,
                    PayoutRounding::Ratio1e9 => stake * (ks * 1_000_000_000 / sum) / 1_000_000_000,
                };
                u64::try_from(units).expect("a share is at most the stake")
            };
            if k > 0 && sum_penalised > 0 {
                let bonus = share(sum_rewarded, false);
                base.checked_add(bonus).expect("pool fits u64")
            } else if k < 0 {
                let penalty = share(sum_penalised, true);
                base.saturating_sub(penalty)
            } else {
                base
            }
        })
        .collect();
    let paid: u128 = out.iter().map(|&u| u128::from(u)).sum();
    assert!(
        rounding == PayoutRounding::Ratio1e9 || paid <= u128::from(pool_units),
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

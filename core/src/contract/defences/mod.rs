//! Defences against reward farming (`contract.defence`; issue 16, beyond the paper).
//!
//! The paper's reward rule pays closeness to the median distance from the shared model and
//! weights the bonus by the *claimed* sample count. A `smart` robot that never collects data or
//! trains (`w(t) + 2 r Delta`, claiming 200 samples) sits close to that median once a few of
//! them are in a round, and out-earns the honest robots (REPRODUCTION.md, claim 12). Its model
//! carries no information the chain did not already hold. A defence replaces the *reward rule*
//! (never the aggregation: the rule in `contract.rule` still decides the model and which
//! submissions it used) by one that pays for information: each used submission is scored by how
//! well its update agrees with the updates of the *other* used submissions of the round, and the
//! pool is shared by score. Claimed sample counts play no part in the payout (they are
//! unverifiable). So a defence combines with every staking rule (`paper`, `krum`, `median`, ...).
//!
//! - [`agreement`]: the score is the cosine between the submission's centered update and the
//!   mean centered update of the others (leave-one-out).
//! - [`innovation`]: the same after removing, from every update, its component along the last
//!   public step `w(t) - w(t-1)`: only what the chain could not predict earns.
//!
//! # Payout, exactly
//!
//! With pool `P` (as for the rule: everything the contract holds), `u` used submissions in the
//! rule's order and scores `s_k` in `[-10^9, 10^9]` (10^9 = full agreement):
//! `base = floor(floor(P * refund_percent / 100) / u)` for everyone (`contract.defence_refund_percent`,
//! the part of the pool that is a flat refund), `B = P - u * base` the bonus pool, and
//! `bonus_k = floor(B * max(s_k, 0) / sum_j max(s_j, 0))` (`floor(B / u)` for everyone when no
//! score is positive). Payout `base + bonus_k`; what the floors leave stays in the contract
//! and rolls into the next pool. `sum(payouts) <= P` always, so tokens are conserved exactly.
//! A submission that agrees with nobody gets `base` back: with the default 50 % and a round of
//! seven 5-token stakes, 2.5 tokens, the same as the paper's penalised rank.
//!
//! # Scores, exactly (integers only)
//!
//! `u_k = w_k - w(t)` (`|u_k,i| < 2^48`); centered: `c_k,i = u_k,i - m_k` with
//! `m_k = round(sum_i u_k,i / N)` (ties away from zero); the reference of `k` is
//! `r_k,i = round((sum_j c_j,i - c_k,i) / (u - 1))`; the score is
//! `cos(c_k, r_k) = (dot / isqrt(|r|^2)) * 10^9 / isqrt(|c|^2)`, each division truncated
//! toward zero, clamped to `[-10^9, 10^9]`; 0 when either norm is 0 (a resubmitted shared
//! model) or `u = 1`. Both vectors are first scaled by a power of two so that their largest
//! coordinate has 49 bits (a cosine does not see the scale): every dot product is exact in
//! `i128` and the result is within one unit of the exact cosine times 10^9. Centring removes the mean of each update: the paper's `smart` adds *positive* noise
//! to every weight, and without centring several smart robots would agree with each other
//! through that shared sign alone.

pub mod agreement;
pub mod innovation;

use serde::{Deserialize, Serialize};

use super::payout::div_round_half_away;
pub use super::rules::isqrt;
use crate::config::Defence;

/// The defence in force in a contract (see [`super::ContractParams::defence`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DefenceParams {
    /// The defence (never `none`: no defence is `None` in the parameters).
    pub defence: Defence,
    /// Percent of the pool refunded in equal parts to the used submissions (0..=100).
    pub refund_percent: u32,
}

/// Bits of the largest coordinate after [`normalise`]: coordinates lie in `[2^48, 2^49)` in
/// magnitude, so a dot product over `2^16` coordinates stays below `2^114`.
const NORMAL_BITS: u32 = 49;

/// The scores (10^9 units) of `models` (the used submissions, in payout order) against the
/// shared model `shared`; `previous` is w(t-1) (used by `innovation`).
pub fn scores(
    defence: Defence,
    shared: &[i64],
    previous: Option<&[i64]>,
    models: &[&[i64]],
) -> Vec<i64> {
    let mut updates: Vec<Vec<i128>> = models.iter().map(|m| centered_update(m, shared)).collect();
    match defence {
        Defence::None | Defence::Agreement => {}
        Defence::Innovation => {
            if let Some(prev) = previous {
                innovation::detrend(&mut updates, shared, prev);
            }
        }
    }
    leave_one_out_cosines(updates)
}

/// `w - w(t)` minus its rounded mean coordinate.
pub fn centered_update(model: &[i64], shared: &[i64]) -> Vec<i128> {
    assert_eq!(model.len(), shared.len(), "models of different lengths");
    let mut u: Vec<i128> = model
        .iter()
        .zip(shared)
        .map(|(&w, &s)| i128::from(w) - i128::from(s))
        .collect();
    center(&mut u);
    u
}

/// Subtracts the rounded mean coordinate from `v` (non-empty).
pub fn center(v: &mut [i128]) {
    if v.is_empty() {
        return;
    }
    let mean = div_round_half_away(v.iter().sum::<i128>(), v.len() as i128);
    for x in v.iter_mut() {
        *x -= mean;
    }
}

/// `v` scaled by a power of two so that its largest coordinate has [`NORMAL_BITS`] bits
/// (left shifts are exact; a right shift only happens for coordinates beyond `2^49`). A cosine
/// does not see the scale, and the normalised vectors keep its rounding error below `2^-47`.
fn normalise(v: &[i128]) -> Vec<i128> {
    let max = v.iter().map(|x| x.unsigned_abs()).max().unwrap_or(0);
    if max == 0 {
        return v.to_vec();
    }
    let bits = 128 - max.leading_zeros();
    if bits > NORMAL_BITS {
        v.iter().map(|&x| x >> (bits - NORMAL_BITS)).collect()
    } else {
        v.iter().map(|&x| x << (NORMAL_BITS - bits)).collect()
    }
}

/// `sum_i a_i b_i`, exact for normalised vectors (at most `2^16` coordinates) and for any two
/// vectors whose coordinates are below `2^49`.
pub fn dot_exact(a: &[i128], b: &[i128]) -> i128 {
    a.iter().zip(b).map(|(&x, &y)| x * y).sum()
}

/// `cos(a, b)` in 10^9 units (see the module doc for the rounding); 0 if either is zero.
pub fn cosine_1e9(a: &[i128], b: &[i128]) -> i64 {
    let (a, b) = (normalise(a), normalise(b));
    let na = isqrt(dot_exact(&a, &a) as u128) as i128;
    let nb = isqrt(dot_exact(&b, &b) as u128) as i128;
    if na == 0 || nb == 0 {
        return 0;
    }
    let c = dot_exact(&a, &b) / nb * 1_000_000_000 / na;
    c.clamp(-1_000_000_000, 1_000_000_000) as i64
}

/// The leave-one-out cosine of every vector with the mean of the others; 0 for a single one.
fn leave_one_out_cosines(vectors: Vec<Vec<i128>>) -> Vec<i64> {
    let u = vectors.len();
    if u < 2 {
        return vec![0; u];
    }
    let n = vectors[0].len();
    let total: Vec<i128> = (0..n).map(|i| vectors.iter().map(|v| v[i]).sum()).collect();
    let others = (u - 1) as i128;
    vectors
        .iter()
        .map(|v| {
            let reference: Vec<i128> = (0..n)
                .map(|i| div_round_half_away(total[i] - v[i], others))
                .collect();
            cosine_1e9(v, &reference)
        })
        .collect()
}

/// The payouts of `pool_units` for the `scores` (module doc): a flat refund of
/// `refund_percent` of the pool in equal parts, the rest shared by positive score.
/// `sum <= pool_units`.
pub fn payouts(pool_units: u64, scores: &[i64], refund_percent: u32) -> Vec<u64> {
    assert!(!scores.is_empty(), "a rule uses at least one submission");
    assert!(refund_percent <= 100, "a percentage");
    let u = scores.len() as u128;
    let pool = u128::from(pool_units);
    let base = pool * u128::from(refund_percent) / 100 / u;
    let bonus_pool = pool - base * u;
    let positive: Vec<u128> = scores.iter().map(|&s| s.max(0) as u128).collect();
    let sum: u128 = positive.iter().sum();
    let out: Vec<u64> = positive
        .iter()
        .map(|&p| {
            // No positive score (sum 0): the bonus pool in equal parts.
            let bonus = (bonus_pool * p).checked_div(sum).unwrap_or(bonus_pool / u);
            u64::try_from(base + bonus).expect("a payout is at most the pool")
        })
        .collect();
    assert!(
        out.iter().map(|&x| u128::from(x)).sum::<u128>() <= pool,
        "defence payouts exceed the pool"
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payouts_refund_half_and_share_the_rest_by_positive_score() {
        fn check(pool: u64, scores: &[i64], refund: u32, expect: &[u64]) {
            assert_eq!(payouts(pool, scores, refund), expect);
        }
        // P = 35, base = floor(17 / 7) = 2, B = 21; scores 3:1 among two positives.
        check(35, &[300, 100, 0, -5, 0, 0, 0], 50, &[17, 7, 2, 2, 2, 2, 2]);
        // No positive score: everyone gets base + floor(B / u).
        check(35, &[0, -1, -1_000_000_000], 50, &[11, 11, 11]);
        // 0 % refund: everything by score; 100 %: equal shares.
        check(100, &[1, 1, 2], 0, &[25, 25, 50]);
        check(100, &[1, 1, 2], 100, &[33, 33, 33]);
        // Full-scale numbers: 35 tokens of 1e9 units.
        let p = payouts(35_000_000_000, &[500_000_000, 500_000_000, 0], 50);
        // base = floor(17.5e9 / 3), B = 35e9 - 3 base, halves of B to the two agreeing.
        assert_eq!(p, vec![14_583_333_333, 14_583_333_333, 5_833_333_333]);
    }

    #[test]
    fn cosine_of_hand_computed_vectors() {
        assert_eq!(cosine_1e9(&[1, 0], &[0, 1]), 0);
        assert_eq!(cosine_1e9(&[3, 4], &[3, 4]), 1_000_000_000);
        assert_eq!(cosine_1e9(&[3, 4], &[-6, -8]), -1_000_000_000);
        // (3*4 + 4*3) / (5 * 5) = 0.96.
        assert!((cosine_1e9(&[3, 4], &[4, 3]) - 960_000_000).abs() <= 1);
        assert_eq!(cosine_1e9(&[0, 0], &[1, 2]), 0);
    }

    #[test]
    fn centring_removes_a_common_offset() {
        let u = centered_update(&[11, 12, 13, 14], &[0, 0, 0, 0]);
        // Mean 12.5 rounds to 13.
        assert_eq!(u, vec![-2, -1, 0, 1]);
    }

    #[test]
    fn a_resubmitted_shared_model_and_a_lone_submission_score_zero() {
        let shared = [5i64, -5, 7, 9];
        let honest_a = [6i64, -7, 9, 8];
        let honest_b = [7i64, -6, 8, 9];
        let s = scores(
            Defence::Agreement,
            &shared,
            None,
            &[&shared[..], &honest_a[..], &honest_b[..]],
        );
        assert_eq!(s[0], 0);
        assert!(s[1] > 0 && s[2] > 0, "{s:?}");
        assert_eq!(
            scores(Defence::Agreement, &shared, None, &[&honest_a[..]]),
            vec![0]
        );
    }

    #[test]
    fn huge_updates_are_scaled_not_overflowed() {
        let limit = (1i64 << 47) - 1;
        let shared = vec![-limit; 1 << 16];
        let a: Vec<i64> = (0..1 << 16)
            .map(|i| if i % 2 == 0 { limit } else { -limit })
            .collect();
        let b = vec![limit; 1 << 16];
        let s = scores(
            Defence::Innovation,
            &shared,
            Some(&b[..]),
            &[&a[..], &b[..], &a[..]],
        );
        assert!(s
            .iter()
            .all(|x| (-1_000_000_000..=1_000_000_000).contains(x)));
    }
}

//! `innovation` (`contract.defence = "innovation"`): as [`super::agreement`], after removing
//! from every update the part the chain already predicts: its component along the last public
//! step `w(t) - w(t-1)` (centered). What remains is what the submitter's own data and training
//! added this round; a robot is paid for agreeing with the others on *that*.
//!
//! Exactly: `e` = the centered `w(t) - w(t-1)`, `e_hat_i = round(e_i * 2^30 / isqrt(|e|^2))`
//! (a unit vector in 2^30 fixed point); each centered update `c` becomes
//! `c_i - round((c . e_hat) * e_hat_i / 2^60)`; then the scores and payouts of [`super`]. In
//! round 0 (no w(t-1)) or after a step of zero it is `agreement`.
//!
//! Why: a trend extrapolation `w(t) + a (w(t) - w(t-1))`, the strongest guess a robot without
//! data can make from the chain alone, lies along `e` and scores exactly 0 (up to rounding),
//! where under `agreement` it would score as much as consecutive SGD steps agree.
//!
//! Costs: as `agreement` plus one projection per submission (`O(u N)`); no bytes, no
//! transaction, no round. It pays honest robots less than `agreement` when their steps mostly
//! continue the last one (that part no longer earns), so their bonus is noisier.
//!
//! Where it fails: copying the round's honest submissions (as `agreement`: the copy carries
//! the honest innovation); coalitions submitting one agreed update; an extrapolation along
//! any other public direction (e.g. the step before last) keeps whatever agreement that
//! direction has with the present one.

use super::{center, dot_exact, isqrt};
use crate::contract::payout::div_round_half_away;

/// Removes from each of `updates` (centered, coordinates below 2^49) its component along the
/// centered step `shared - previous`.
pub fn detrend(updates: &mut [Vec<i128>], shared: &[i64], previous: &[i64]) {
    assert_eq!(shared.len(), previous.len(), "models of different lengths");
    let mut step: Vec<i128> = shared
        .iter()
        .zip(previous)
        .map(|(&w, &p)| i128::from(w) - i128::from(p))
        .collect();
    center(&mut step);
    let norm = isqrt(dot_exact(&step, &step) as u128) as i128;
    if norm == 0 {
        return;
    }
    let unit: Vec<i128> = step
        .iter()
        .map(|&x| div_round_half_away(x << 30, norm))
        .collect();
    for u in updates.iter_mut() {
        let beta = dot_exact(u, &unit);
        for (x, &e) in u.iter_mut().zip(&unit) {
            *x -= div_round_half_away(beta * e, 1 << 60);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{scores, Defence};

    /// An extrapolation of the last step scores about 0 under `innovation` but well under
    /// `agreement` when the honest steps continue the trend.
    #[test]
    fn a_trend_extrapolation_earns_nothing_but_new_information_does() {
        let n = 1000usize;
        let previous: Vec<i64> = vec![0; n];
        // The last step: +-1e6 alternating in blocks (centered).
        let trend: Vec<i64> = (0..n)
            .map(|i| if i % 4 < 2 { 1_000_000 } else { -1_000_000 })
            .collect();
        let shared: Vec<i64> = trend.clone();
        // Something new that the honest robots all found: +-1e6 in another pattern.
        let fresh: Vec<i64> = (0..n)
            .map(|i| if i % 2 == 0 { 1_000_000 } else { -1_000_000 })
            .collect();
        let honest = |k: i64| -> Vec<i64> {
            (0..n)
                .map(|i| {
                    shared[i] + trend[i] + fresh[i] + ((i as i64 * 7 + k * 13) % 17 - 8) * 50_000
                })
                .collect()
        };
        let (h1, h2, h3) = (honest(1), honest(2), honest(3));
        let extrapolation: Vec<i64> = (0..n).map(|i| shared[i] + trend[i]).collect();
        let models: Vec<&[i64]> = vec![&h1[..], &h2[..], &h3[..], &extrapolation[..]];
        let a = scores(Defence::Agreement, &shared, Some(&previous[..]), &models);
        let v = scores(Defence::Innovation, &shared, Some(&previous[..]), &models);
        assert!(a[3] > 500_000_000, "agreement pays the trend: {a:?}");
        assert!(v[3].abs() < 10_000_000, "innovation does not: {v:?}");
        for k in 0..3 {
            assert!(v[k] > 500_000_000, "honest innovations agree: {v:?}");
        }
        // Without w(t-1) innovation is agreement.
        assert_eq!(scores(Defence::Innovation, &shared, None, &models), a);
    }
}

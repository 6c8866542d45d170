//! `agreement` (`contract.defence = "agreement"`): rewards follow how well a submission's update
//! agrees with the other used submissions' updates of its round, not its distance to the median
//! distance, and not its claimed sample count.
//!
//! Score: the cosine between the submission's centered update `w_k - w(t)` and the mean centered
//! update of the *other* used submissions (leave-one-out, so a model cannot agree with itself);
//! payout: a flat refund of `contract.defence_refund_percent` of the pool, the rest shared in
//! proportion to the positive scores (both exactly in [`super`]'s module doc).
//!
//! Why it works against `smart`: honest robots train on trajectories of the same arena, so their
//! steps share a direction (the gradient of the common task); the smart robot's step is noise
//! around w(t) whose only common part, a positive offset on every weight, centring removes. Its
//! expected score is 0 whoever else is in the round, so it gets the refund and loses the rest
//! of its stake, while the honest robots share the bonus. A resubmitted shared model
//! (`malicious`) has no update and scores 0; a `faulty` model is rejected by the rule before.
//!
//! Costs: no bytes, no transaction, no round: the contract computes `u` leave-one-out cosines
//! over `N` weights at each aggregation (`O(u N)` integer operations, about 7 x 2848 x 4
//! multiply-adds per round here; under the EVM this would be about 10^6 gas, and the `evm`
//! engine refuses defences).
//!
//! Where it fails (what an attacker must do to beat it):
//! - *Copying*: a Byzantine robot reads the round's honest submissions on its chain before it
//!   submits, and can copy one (`mimic`) or their mean: it then agrees as well as an honest
//!   robot and is paid like one, without data or training. The defence stops *out-earning*
//!   (the copy is paid no more than its source) but not free riding; hiding the models until
//!   the round is closed (commit, then reveal) is what would stop copying, at the cost of a
//!   second transaction per submission and a round's delay.
//! - *Trend extrapolation*: `w(t) + a (w(t) - w(t-1))` agrees with the honest steps as much as
//!   consecutive steps of SGD agree with each other. [`super::innovation`] removes that part.
//! - *Coalitions*: robots that submit one agreed update agree with each other; a coalition that
//!   is a large part of the used submissions of a round scores well on its own agreement.
//! - Honest robots whose data differ from the others' (a robot alone in a corner) agree less
//!   and earn less: the defence pays for typical data, not for useful rare data.

#[cfg(test)]
mod tests {
    use super::super::{payouts, scores, Defence};
    use crate::rng::{self, Purpose};

    /// Three honest steps share a direction; three smart ones are positive noise of the same
    /// size: the honest score well, the smart near 0, and the honest share the bonus.
    #[test]
    fn smart_noise_scores_near_zero_and_honest_steps_share_the_pool() {
        let n = 2848;
        let mut rng = rng::stream(1, Purpose::Byzantine, 0);
        let shared: Vec<i64> = (0..n).map(|i| (i as i64 % 11 - 5) * 10_000_000).collect();
        let direction: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let mut models: Vec<Vec<i64>> = Vec::new();
        for _ in 0..3 {
            models.push(
                shared
                    .iter()
                    .zip(&direction)
                    .map(|(&w, &d)| w + ((d + rng.normal()) * 1e6) as i64)
                    .collect(),
            );
        }
        for _ in 0..3 {
            models.push(
                shared
                    .iter()
                    .map(|&w| w + (2.0 * rng.uniform() * 1e6) as i64)
                    .collect(),
            );
        }
        let refs: Vec<&[i64]> = models.iter().map(|m| &m[..]).collect();
        let s = scores(Defence::Agreement, &shared, None, &refs);
        for &h in &s[..3] {
            assert!(h > 400_000_000, "honest {s:?}");
        }
        for &b in &s[3..] {
            assert!(b.abs() < 80_000_000, "smart {s:?}");
        }
        let pay = payouts(30_000_000_000, &s, 50);
        // Each gets base = 2.5e9 back; the honest share almost all of the 15e9 bonus.
        let honest: u64 = pay[..3].iter().sum();
        assert!(honest > 20_000_000_000, "{pay:?}");
        assert!(pay[3..].iter().all(|&p| p < 3_500_000_000), "{pay:?}");
    }
}

//! `min-max` (Shejwalkar and Houmansadr, 2021): `w = mu + gamma * p` with `mu` the mean of the
//! round's honest models on the robot's chain, `p = -sigma` (minus the per-weight honest
//! standard deviation), and `gamma` the largest value for which the forged model is no farther
//! (Euclidean) from any honest model than the two farthest honest models are from each other:
//! `max_i |w - h_i| <= max_{i,j} |h_i - h_j|`. It looks no more deviant than the honest spread
//! while pushing as far as that allows.
//!
//! `gamma` search, in `f64`: start at 1 and double while the condition holds (at most 2^20),
//! then [`BISECTIONS`] bisection steps between the last good and the first bad value; the
//! result is the last good value (0 if even 1 fails and no bisection succeeds). When every
//! honest model is identical, `p = 0` and the robot sends `mu`.
//!
//! Waits until `max(byzantine.wait_for_honest, 2)` honest models of the round are on its
//! chain. Information: the round's honest submissions. Parameters:
//! `byzantine.wait_for_honest`, `byzantine.claimed_samples`.

use super::{await_honest, mean, std_dev, submit, to_f32, Action, Attack, View};
use crate::rng::Rng;

/// Bisection steps of the `gamma` search.
pub const BISECTIONS: usize = 30;

/// The `min-max` agent.
pub struct MinMax;

fn distance(a: &[f64], b: &[f32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = x - f64::from(y);
            d * d
        })
        .sum::<f64>()
        .sqrt()
}

/// The min-max model of `honest` (at least one model).
pub fn forge(honest: &[Vec<f32>]) -> Vec<f32> {
    let mu = mean(honest);
    let p: Vec<f64> = std_dev(honest, &mu).iter().map(|s| -s).collect();
    let mut spread = 0.0f64;
    for (i, a) in honest.iter().enumerate() {
        let a64: Vec<f64> = a.iter().map(|&x| f64::from(x)).collect();
        for b in &honest[i + 1..] {
            spread = spread.max(distance(&a64, b));
        }
    }
    let at = |gamma: f64| -> Vec<f64> { mu.iter().zip(&p).map(|(&m, &q)| m + gamma * q).collect() };
    let ok = |gamma: f64| -> bool {
        let w = at(gamma);
        honest.iter().all(|h| distance(&w, h) <= spread)
    };
    let (mut good, mut bad) = (0.0f64, 1.0f64);
    while ok(bad) && bad < f64::from(1u32 << 20) {
        good = bad;
        bad *= 2.0;
    }
    for _ in 0..BISECTIONS {
        let mid = (good + bad) / 2.0;
        if ok(mid) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    to_f32(&at(good))
}

impl Attack for MinMax {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        let need = (view.config.wait_for_honest as usize).max(2);
        match await_honest(view, need) {
            Some(honest) => submit(view, forge(&honest)),
            None => Action::Wait,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pushes_to_the_edge_of_the_honest_spread() {
        // Honest 0 and 2 (one weight): mu 1, sigma 1, p = -1, spread 2.
        // |1 - gamma - 0| <= 2 and |1 - gamma - 2| <= 2  ->  gamma <= 1 (the second binds at
        // gamma = 1: |-2| = 2). So w = 0.
        let w = forge(&[vec![0.0f32], vec![2.0]]);
        assert!((w[0] - 0.0).abs() < 1e-6, "{w:?}");
        // Identical honest models: p = 0, the mean.
        assert_eq!(forge(&[vec![0.5f32, 1.0], vec![0.5, 1.0]]), vec![0.5, 1.0]);
    }
}

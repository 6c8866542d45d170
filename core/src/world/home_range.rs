//! Home ranges of the avoidance walk (`world.home_range`, docs/GUIDE.md "Home ranges"): the
//! arena is split into a square grid of regions; each robot draws a preference vector over
//! them from a Dirichlet(`alpha`) and, at the start of each goal period, picks its current
//! region from it. `controller.rs` pulls a robot that is outside its current region toward the
//! region's centre (`steering::pull`), after obstacle avoidance, which keeps priority.
//!
//! Everything here is re-derived from the seed: the preferences from the robot's
//! `Purpose::HomeRange` stream, a period's pick from the substream of that period, so the
//! current region depends only on (seed, robot, time). Nothing needs to be in the reduced
//! world state: the controllers stay driver-side state that replay does not read (it folds
//! the tick events), and a fork re-runs them from time 0 (`world.*` is not reconfigurable).

use crate::config::HomeRangeConfig;
use crate::rng::{self, Purpose, Rng};
use crate::types::RobotId;

/// The home ranges of a swarm (built only when the knob is on).
#[derive(Clone, Debug)]
pub(super) struct HomeRanges {
    seed: u64,
    /// The grid's side in regions.
    side: u32,
    /// Each region's side in metres.
    region_m: f64,
    /// The arena's half side in metres (the grid starts at `-half`).
    half_m: f64,
    /// Goal period in milliseconds of simulated time.
    period_ms: u64,
    /// Per robot: the cumulative preference over the regions (the last entry is 1).
    cumulative: Vec<Vec<f64>>,
}

impl HomeRanges {
    /// The home ranges of `robots` robots in an arena of side `arena_side_m`, seeded with
    /// `seed`; `None` when `config` is off (`alpha = "inf"`).
    pub(super) fn new(
        config: &HomeRangeConfig,
        arena_side_m: f64,
        robots: u32,
        seed: u64,
    ) -> Option<HomeRanges> {
        if !config.is_on() {
            return None;
        }
        let side = config
            .side()
            .expect("a validated world.home_range.regions is a square");
        let cumulative = (0..robots)
            .map(|i| {
                let mut r = rng::stream(seed, Purpose::HomeRange, i);
                cumulative(&dirichlet(&mut r, config.alpha, config.regions as usize))
            })
            .collect();
        Some(HomeRanges {
            seed,
            side,
            region_m: arena_side_m / f64::from(side),
            half_m: 0.5 * arena_side_m,
            period_ms: ((config.goal_period_s * 1000.0).round() as u64).max(1),
            cumulative,
        })
    }

    /// The region `robot` heads for at `time_ms`: the pick of its goal period, from the
    /// substream of that period.
    pub(super) fn current(&self, robot: RobotId, time_ms: u64) -> usize {
        let period = time_ms / self.period_ms;
        let mut r = rng::substream(self.seed, Purpose::HomeRange, robot, period);
        let u = r.uniform();
        let c = &self.cumulative[robot as usize];
        c.iter().position(|&p| u < p).unwrap_or(c.len() - 1)
    }

    /// The region that holds the point (x, y) (a point on or beyond a wall counts in the
    /// border region).
    pub(super) fn region_of(&self, x: f64, y: f64) -> usize {
        let cell = |v: f64| {
            let k = ((v + self.half_m) / self.region_m).floor();
            if k.is_nan() || k < 0.0 {
                0
            } else {
                (k as u32).min(self.side - 1)
            }
        };
        (cell(y) * self.side + cell(x)) as usize
    }

    /// The centre of `region` in metres.
    pub(super) fn centre(&self, region: usize) -> (f64, f64) {
        let side = self.side as usize;
        let (row, col) = (region / side, region % side);
        (
            -self.half_m + (col as f64 + 0.5) * self.region_m,
            -self.half_m + (row as f64 + 0.5) * self.region_m,
        )
    }

    /// Robot `robot`'s preference for each region (for tests and measures).
    #[cfg(test)]
    pub(super) fn preferences(&self, robot: RobotId) -> Vec<f64> {
        let c = &self.cumulative[robot as usize];
        (0..c.len())
            .map(|k| c[k] - if k == 0 { 0.0 } else { c[k - 1] })
            .collect()
    }
}

/// A Dirichlet(`alpha`, ..., `alpha`) draw over `n` regions: Gamma(`alpha`) draws normalised,
/// in logarithms (the largest is 1 before normalising) so that small `alpha` cannot make every
/// weight underflow.
fn dirichlet(r: &mut Rng, alpha: f64, n: usize) -> Vec<f64> {
    let logs: Vec<f64> = (0..n).map(|_| r.ln_gamma_draw(alpha)).collect();
    let top = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let weights: Vec<f64> = logs.iter().map(|&l| libm::exp(l - top)).collect();
    let total: f64 = weights.iter().sum();
    weights.iter().map(|w| w / total).collect()
}

/// The running sum of `p`, its last entry forced to 1 (so a uniform draw below 1 always picks
/// a region).
fn cumulative(p: &[f64]) -> Vec<f64> {
    let mut sum = 0.0;
    let mut out: Vec<f64> = p
        .iter()
        .map(|&x| {
            sum += x;
            sum
        })
        .collect();
    if let Some(last) = out.last_mut() {
        *last = 1.0;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ranges(alpha: f64) -> HomeRanges {
        let config = HomeRangeConfig {
            regions: 9,
            alpha,
            goal_period_s: 30.0,
        };
        HomeRanges::new(&config, 6.0, 50, 7).expect("on")
    }

    #[test]
    fn regions_tile_the_arena_and_centres_lie_in_their_region() {
        let h = ranges(1.0);
        for k in 0..9 {
            let (x, y) = h.centre(k);
            assert_eq!(h.region_of(x, y), k);
        }
        assert_eq!(h.region_of(-3.0, -3.0), 0);
        assert_eq!(h.region_of(2.9, -2.9), 2);
        assert_eq!(h.region_of(-2.9, 2.9), 6);
        assert_eq!(h.region_of(9.0, 9.0), 8);
        assert_eq!(h.centre(4), (0.0, 0.0));
    }

    #[test]
    fn small_alpha_concentrates_preferences_and_large_alpha_spreads_them() {
        // The largest preference, averaged over 50 robots: near 1 at alpha 0.1, near 1/9 at
        // alpha 100.
        let top = |alpha: f64| {
            let h = ranges(alpha);
            (0..50)
                .map(|i| h.preferences(i).into_iter().fold(0.0, f64::max))
                .sum::<f64>()
                / 50.0
        };
        assert!(top(0.1) > 0.7, "{}", top(0.1));
        assert!(top(100.0) < 0.2, "{}", top(100.0));
        for i in 0..50 {
            let sum: f64 = ranges(0.1).preferences(i).iter().sum();
            assert!((sum - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn a_pick_is_fixed_within_a_period_and_follows_the_preferences() {
        let h = ranges(0.1);
        let mut hits = [0u32; 9];
        for period in 0..400u64 {
            let at = h.current(3, period * 30_000);
            assert_eq!(h.current(3, period * 30_000 + 29_999), at);
            hits[at] += 1;
        }
        let p = h.preferences(3);
        let best = (0..9).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap();
        assert!(
            f64::from(hits[best]) / 400.0 > p[best] - 0.1,
            "{hits:?} {p:?}"
        );
    }
}

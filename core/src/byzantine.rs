//! Byzantine robots (SPEC.md section 5): which robots they are and the weights they forge.
//!
//! Byzantine robots move and run nodes like everyone, but never train: at each training phase
//! the driver calls [`forge`] instead of training and submits the result (converted to fixed
//! point by the learning module) with `byzantine.claimed_samples` samples.
//!
//! The formulas, for the shared model w(t) read from the robot's own chain and w(t-1) the model
//! before the last aggregation (`None` in round 0):
//! - faulty: every weight uniform in `[-faulty_range, faulty_range)` (both variants; the paper's
//!   interval is TensorFlow's initialisation range, 0.5).
//! - malicious: w(t) itself (both variants).
//! - smart, paper: `w_i(t) + 2 r_i Delta`, `Delta = (1/N) sum_i |w_i(t) - w_i(t-1)|`, `r_i`
//!   uniform in [0, 1) drawn per weight, always N draws. In round 0 there is no w(t-1): we take
//!   `Delta = 0`, so the robot sends w(t) (the formula with w(t-1) = w(t)).
//! - smart, reference: positive-only noise of the magnitude of one step, `w_i(t) + r_i Delta`
//!   with `r_i` uniform in [0, 1) (our reading of SPEC.md: the paper's variation `2 r Delta`
//!   has mean Delta and reaches 2 Delta, the reference's stays within one Delta above w(t)),
//!   and w(t) unchanged, with no draws, before the first change (no w(t-1), or Delta == 0).
//!
//! `Delta` is summed in `f64` in index order; noise is added in `f64` and rounded once to
//! `f32`. No fused multiply-add, so results are the same on every platform.

pub mod ledger;

use crate::config::{ByzantineKind, ByzantineVariant, Config};
use crate::rng::{self, Purpose, Rng};

/// The weights a Byzantine robot of `kind` submits (before fixed point). `shared` is w(t),
/// `previous` is w(t-1) (same length) or `None` before the first aggregation; `rng` is the
/// robot's `Purpose::Byzantine` stream. `ByzantineKind::None` forges nothing: it returns w(t).
pub fn forge(
    kind: ByzantineKind,
    variant: ByzantineVariant,
    shared: &[f32],
    previous: Option<&[f32]>,
    faulty_range: f64,
    rng: &mut Rng,
) -> Vec<f32> {
    match kind {
        ByzantineKind::None | ByzantineKind::Malicious => shared.to_vec(),
        ByzantineKind::Faulty => {
            assert!(
                faulty_range.is_finite() && faulty_range >= 0.0,
                "faulty_range {faulty_range}"
            );
            (0..shared.len())
                .map(|_| rng.range(-faulty_range, faulty_range) as f32)
                .collect()
        }
        ByzantineKind::Smart => {
            let step = previous.map_or(0.0, |p| delta(shared, p));
            match variant {
                ByzantineVariant::Paper => shared
                    .iter()
                    .map(|&w| (f64::from(w) + 2.0 * rng.uniform() * step) as f32)
                    .collect(),
                ByzantineVariant::Reference if step == 0.0 => shared.to_vec(),
                ByzantineVariant::Reference => shared
                    .iter()
                    .map(|&w| (f64::from(w) + rng.uniform() * step) as f32)
                    .collect(),
            }
        }
    }
}

/// `Delta(w(t), w(t-1)) = (1/N) sum_i |w_i(t) - w_i(t-1)|`, in `f64`, summed in index order.
/// 0 for empty models.
pub fn delta(current: &[f32], previous: &[f32]) -> f64 {
    assert_eq!(
        current.len(),
        previous.len(),
        "Delta between models of different lengths"
    );
    if current.is_empty() {
        return 0.0;
    }
    let sum: f64 = current
        .iter()
        .zip(previous)
        .map(|(&a, &b)| (f64::from(a) - f64::from(b)).abs())
        .sum();
    sum / current.len() as f64
}

/// Which robots are Byzantine: `byzantine.count` of the `world.robots`, drawn without
/// replacement (a partial Fisher-Yates shuffle) from the `Purpose::ByzantineSelection` stream,
/// so they are spread over the ids and change with the seed. Index = robot id.
pub fn byzantine_robots(config: &Config, seed: u64) -> Vec<bool> {
    let robots = config.world.robots as usize;
    let count = (config.byzantine.count as usize).min(robots);
    let mut ids: Vec<usize> = (0..robots).collect();
    let mut rng = rng::stream(seed, Purpose::ByzantineSelection, 0);
    for i in 0..count {
        let j = i + rng.below((robots - i) as u64) as usize;
        ids.swap(i, j);
    }
    let mut byzantine = vec![false; robots];
    for &id in &ids[..count] {
        byzantine[id] = true;
    }
    assert_eq!(byzantine.iter().filter(|&&b| b).count(), count);
    byzantine
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Preset;

    fn stream() -> Rng {
        rng::stream(42, Purpose::Byzantine, 3)
    }

    fn forge_with(
        kind: ByzantineKind,
        variant: ByzantineVariant,
        shared: &[f32],
        previous: Option<&[f32]>,
    ) -> Vec<f32> {
        forge(kind, variant, shared, previous, 0.5, &mut stream())
    }

    #[test]
    fn faulty_weights_are_uniform_in_the_range_and_seeded() {
        let shared = vec![3.0f32; 10_000];
        let w = forge_with(
            ByzantineKind::Faulty,
            ByzantineVariant::Paper,
            &shared,
            None,
        );
        assert!(w.iter().all(|x| (-0.5..=0.5).contains(x)));
        let mean = w.iter().map(|&x| f64::from(x)).sum::<f64>() / w.len() as f64;
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!(w.iter().any(|&x| x < -0.45) && w.iter().any(|&x| x > 0.45));
        assert_eq!(
            w,
            forge_with(
                ByzantineKind::Faulty,
                ByzantineVariant::Reference,
                &shared,
                None
            )
        );
    }

    #[test]
    fn malicious_resubmits_the_shared_model() {
        let shared = [0.25f32, -1.5, 7.0];
        for variant in [ByzantineVariant::Paper, ByzantineVariant::Reference] {
            assert_eq!(
                forge_with(ByzantineKind::Malicious, variant, &shared, Some(&[0.0; 3])),
                shared
            );
        }
    }

    #[test]
    fn delta_is_the_mean_absolute_change() {
        fn check(current: &[f32], previous: &[f32], expect: f64) {
            assert_eq!(delta(current, previous), expect);
        }
        check(&[1.0, 2.0, 3.0, 4.0], &[0.0, 2.0, 5.0, 4.0], 0.75);
        check(&[-1.0, 1.0], &[1.0, -1.0], 2.0);
        check(&[], &[], 0.0);
    }

    /// Smart, paper: offsets 2 r Delta lie in [0, 2 Delta) and average Delta.
    #[test]
    fn smart_paper_adds_twice_a_uniform_fraction_of_the_last_step() {
        let n = 20_000;
        let shared: Vec<f32> = (0..n).map(|i| (i % 7) as f32 * 0.125).collect();
        let previous: Vec<f32> = shared.iter().map(|w| w - 0.25).collect(); // Delta = 0.25
        let w = forge_with(
            ByzantineKind::Smart,
            ByzantineVariant::Paper,
            &shared,
            Some(&previous),
        );
        let offsets: Vec<f64> = w
            .iter()
            .zip(&shared)
            .map(|(&a, &b)| f64::from(a) - f64::from(b))
            .collect();
        assert!(
            offsets.iter().all(|&o| (0.0..=0.5).contains(&o)),
            "offsets in [0, 2 Delta]"
        );
        let mean = offsets.iter().sum::<f64>() / n as f64;
        assert!((mean - 0.25).abs() < 0.01, "mean offset {mean}, Delta 0.25");
        // Round 0: Delta = 0, the robot sends w(t).
        assert_eq!(
            forge_with(ByzantineKind::Smart, ByzantineVariant::Paper, &shared, None),
            shared
        );
    }

    /// Smart, reference: offsets r Delta lie in [0, Delta) and average Delta / 2; before the
    /// first change w(t) is sent and no random number is drawn.
    #[test]
    fn smart_reference_adds_positive_noise_within_one_step() {
        let n = 20_000;
        let shared: Vec<f32> = (0..n).map(|i| (i % 5) as f32 * -0.5).collect();
        let previous: Vec<f32> = shared.iter().map(|w| w + 0.5).collect(); // Delta = 0.5
        let w = forge_with(
            ByzantineKind::Smart,
            ByzantineVariant::Reference,
            &shared,
            Some(&previous),
        );
        let offsets: Vec<f64> = w
            .iter()
            .zip(&shared)
            .map(|(&a, &b)| f64::from(a) - f64::from(b))
            .collect();
        assert!(offsets.iter().all(|&o| (0.0..=0.5).contains(&o)));
        let mean = offsets.iter().sum::<f64>() / n as f64;
        assert!(
            (mean - 0.25).abs() < 0.01,
            "mean offset {mean}, Delta / 2 = 0.25"
        );
        for previous in [None, Some(&shared[..])] {
            let mut rng = stream();
            let w = forge(
                ByzantineKind::Smart,
                ByzantineVariant::Reference,
                &shared,
                previous,
                0.5,
                &mut rng,
            );
            assert_eq!(w, shared);
            assert_eq!(rng, stream(), "no draws before the first change");
        }
    }

    #[test]
    fn byzantine_robots_are_exactly_count_drawn_from_the_seed() {
        let mut config = Preset::Paper.config();
        for count in [0u32, 1, 3, 7, 15] {
            config.byzantine.count = count;
            let chosen = byzantine_robots(&config, 9);
            assert_eq!(chosen.len(), 15);
            assert_eq!(chosen.iter().filter(|&&b| b).count(), count as usize);
            assert_eq!(chosen, byzantine_robots(&config, 9), "deterministic");
        }
        config.byzantine.count = 3;
        let sets: Vec<Vec<bool>> = (0..8).map(|seed| byzantine_robots(&config, seed)).collect();
        assert!(
            sets.iter().any(|s| *s != sets[0]),
            "the choice depends on the seed"
        );
    }
}

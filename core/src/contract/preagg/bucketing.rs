//! `bucketing` (Karimireddy, He and Jaggi, "Byzantine-Robust Learning on Heterogeneous
//! Datasets via Bucketing", ICLR 2022): shuffle the `n` models, split them into buckets of `s`
//! consecutive models and pass on each bucket's mean,
//!
//! `y_b = mean(x_{pi(b s)}, .., x_{pi(b s + s - 1)})`, `b = 0 .. ceil(n / s) - 1`,
//!
//! where `pi` is a uniform permutation; when `s` does not divide `n` the last bucket holds the
//! `n mod s` remaining models (as ByzFL's `Bucketing`). Averaging `s` honest models divides
//! their heterogeneity's variance by `s`, while each Byzantine model still spoils at most one
//! bucket, so the rule after it faces at most `f` bad models among `ceil(n / s)`.
//!
//! Determinism: `pi` is a Fisher-Yates shuffle driven by blake3's XOF keyed by the round's
//! seed ([`super::shuffle_seed`], chain data every node holds): the draw for position `i`, from
//! `n - 1` down to position one, takes 8 bytes `u` and swaps position `i` with
//! `floor(u * (i + 1) / 2^64)`, a bias below `n / 2^64` and no rejection loop. Means round half away from zero; a bucket's samples are the
//! sum of its members'.

use super::{mean_of, Staged};

/// The permutation of `0..n` drawn from `seed`.
pub fn permutation(n: usize, seed: [u8; 32]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..n).collect();
    let mut xof = blake3::Hasher::new_keyed(&seed).finalize_xof();
    let mut bytes = [0u8; 8];
    for i in (1..n).rev() {
        xof.fill(&mut bytes);
        let u = u128::from(u64::from_le_bytes(bytes));
        let j = ((u * (i as u128 + 1)) >> 64) as usize;
        order.swap(i, j);
    }
    order
}

/// The stage as its line in the [`Preaggregator`](crate::config::Preaggregator) registry
/// names it.
pub struct Bucketing;

impl super::Stage for Bucketing {
    fn apply(&self, models: &[Staged], stage: &super::StageInput) -> Vec<Staged> {
        apply(models, stage.params.bucket_size, stage.seed)
    }
}

/// The bucket means of `models` shuffled by `seed`, buckets of `s` (at least 1).
pub fn apply(models: &[Staged], s: u32, seed: [u8; 32]) -> Vec<Staged> {
    let s = (s as usize).max(1);
    let order = permutation(models.len(), seed);
    order
        .chunks(s)
        .map(|bucket| {
            let members: Vec<&Staged> = bucket.iter().map(|&i| &models[i]).collect();
            mean_of(&members)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::staged_of;
    use super::*;

    #[test]
    fn the_permutation_is_a_seeded_shuffle() {
        let a = permutation(10, [1; 32]);
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..10).collect::<Vec<_>>(), "a permutation");
        assert_eq!(a, permutation(10, [1; 32]), "deterministic");
        assert_ne!(a, permutation(10, [2; 32]), "depends on the seed");
        assert_eq!(permutation(1, [1; 32]), vec![0]);
        assert!(permutation(0, [1; 32]).is_empty());
    }

    #[test]
    fn buckets_average_the_shuffled_models() {
        let models = staged_of(&[&[0], &[10], &[20], &[30], &[41]]);
        let seed = [7; 32];
        let pi = permutation(5, seed);
        let value = |i: usize| models[pi[i]].weights[0];
        // Buckets (pi0, pi1), (pi2, pi3), (pi4): means rounded half away from zero.
        let expect: Vec<i64> = vec![
            (value(0) + value(1) + 1) / 2,
            (value(2) + value(3) + 1) / 2,
            value(4),
        ];
        let out = apply(&models, 2, seed);
        assert_eq!(out.iter().map(|s| s.weights[0]).collect::<Vec<_>>(), expect);
        assert_eq!(
            out.iter().map(|s| s.samples).collect::<Vec<_>>(),
            vec![2, 2, 1]
        );
    }

    #[test]
    fn a_hand_computed_round() {
        // With the identity order (s = n is shuffle-free: one bucket), the mean of 1, 2, 4 is
        // 7 / 3 = 2.33 -> 2; s = 1 keeps every model, in shuffled order.
        let models = staged_of(&[&[1, -1], &[2, -2], &[4, -4]]);
        let one = apply(&models, 3, [9; 32]);
        assert_eq!(one.len(), 1);
        assert_eq!(one[0].weights, vec![2, -2]);
        let singles = apply(&models, 1, [9; 32]);
        let pi = permutation(3, [9; 32]);
        for (b, &i) in pi.iter().enumerate() {
            assert_eq!(singles[b], models[i]);
        }
    }
}

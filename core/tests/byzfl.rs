//! swarmfl's integer rules against ByzFL 0.0.11's own numpy aggregators on the same quantised
//! vectors (issue #33). `scripts/byzfl_fixture.py` ran ByzFL and wrote `tests/data/byzfl.json`
//! (committed, so CI needs neither ByzFL nor Python); this test recomputes every aggregate with
//! swarmfl's code and checks it against ByzFL's within a tolerance derived below.
//!
//! # Tolerances (in fixed-point units, scale 1e9)
//!
//! ByzFL's side: it gets `u / 1e9` as float64 (relative error `2^-53`), sums at most `q`
//! terms (`q 2^-52 max|u|`) and the script multiplies back (`2^-53`): its aggregate is within
//! `F = (q + 2) 2^-52 max|u|` units of the exact real value (about `3e-3` units here).
//!
//! - Mean-like rules (Average = `fedavg` with equal samples, Median, TrMean, MultiKrum, MDA,
//!   MoNNA, Meamed): the selection is exact on both sides (integers vs. floats of the same
//!   values, no near-ties in random data), and swarmfl rounds the one final quotient half away
//!   from zero: `0.5 + F`.
//! - Krum: the chosen model itself: `F`.
//! - CenteredClipping (L = 3, tau and center the same on both sides): per iteration and
//!   coordinate swarmfl's contributions are rounded (their mean is off by at most 0.5), the
//!   step is rounded (0.5), and the clip factor uses `floor(norm)` (`|x_i| tau (1/n' - 1/n) <=
//!   tau / n <= 1` for a clipped model, at most 1 at the clipping boundary): 2 units, so at
//!   most `2 sqrt(len)` in L2. The exact iteration map `v -> v + mean_k clip(x_k - v)` is
//!   1-Lipschitz in L2 (each term is `x_k - (I - P)(x_k - v)`, `I - P` of a projection onto a
//!   ball is nonexpansive), so the errors add: `3 * 2 sqrt(len) + F`.
//! - GeometricMedian (ByzFL run to convergence, T = 5000): swarmfl stops at `z` with
//!   `round(T'(z)) = z` for its quantised Weiszfeld map `T'`; `T'` is within 2 units of the
//!   exact map `T` per coordinate (each weight's relative error is at most `1 / d_k` from the
//!   floored distance plus `2^-64 d_k / d_min` from the floored quotient, and each model is
//!   within `d_k` of `z`), so `|T(z) - z| <= 2.5 sqrt(len)` in L2. Near the median Weiszfeld
//!   contracts with rate `rho < 1` (the script measures it on ByzFL's own iterates), so
//!   `|z - z*| <= |T(z) - z| / (1 - rho)`: `2.5 sqrt(len) / (1 - rho) + F`.
//!
//! Krum and MultiKrum: ByzFL sums `n - f - 1` neighbours where swarmfl's rules (after
//! Blanchard et al.) sum `n - f - 2` (see `rules/krum.rs`); the test checks swarmfl's Krum
//! machinery, [`krum_scores`], with ByzFL's count. MoNNA: ByzFL's pivot is the first vector,
//! swarmfl's rule pivots on the shared model (see `rules/monna.rs`); the test checks
//! [`monna::nearest_mean`] with ByzFL's pivot.

use serde_json::Value;
use swarmfl_core::config::{ContractOptions, Rule};
use swarmfl_core::contract::rules::{self, krum_scores, mean, monna, Input};

fn ints(v: &Value) -> Vec<i64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_i64().expect("an integer"))
        .collect()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn check(name: &str, case: usize, ours: &[i64], theirs: &[f64], tol: f64) -> f64 {
    assert_eq!(ours.len(), theirs.len(), "{name}, case {case}: lengths");
    let mut worst = 0f64;
    for (i, (&a, &b)) in ours.iter().zip(theirs).enumerate() {
        let err = (a as f64 - b).abs();
        worst = worst.max(err);
        assert!(
            err <= tol,
            "{name}, case {case}, weight {i}: swarmfl {a} vs ByzFL {b} (error {err} > {tol})"
        );
    }
    worst
}

#[test]
fn rules_match_byzfl_on_the_same_quantised_vectors() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/byzfl.json");
    let text = std::fs::read_to_string(path).expect("the committed ByzFL fixture");
    let doc: Value = serde_json::from_str(&text).expect("JSON");
    let cases = doc["cases"].as_array().expect("cases");
    assert!(cases.len() >= 10, "the fixture holds the script's cases");
    let options = ContractOptions::default();
    let mut checked = 0;
    for (c, case) in cases.iter().enumerate() {
        let q = case["q"].as_u64().expect("q") as usize;
        let f = case["f"].as_u64().expect("f") as usize;
        let current = ints(&case["current"]);
        let models: Vec<Vec<i64>> = case["models"]
            .as_array()
            .expect("models")
            .iter()
            .map(ints)
            .collect();
        assert_eq!(models.len(), q);
        let len = current.len();
        let refs: Vec<&[i64]> = models.iter().map(|w| &w[..]).collect();
        let inputs: Vec<Input> = refs
            .iter()
            .map(|w| Input {
                weights: w,
                samples: 1,
                distance_units: 0,
            })
            .collect();
        let max_units = models
            .iter()
            .flatten()
            .chain(&current)
            .map(|w| w.unsigned_abs())
            .max()
            .expect("weights") as f64;
        let float = (q as f64 + 2.0) * f64::EPSILON * max_units;
        let by = &case["byzfl"];
        let rule = |r: Rule| r.aggregate(&current, &inputs, f, &options).weights;
        let mean_tol = 0.5 + float;

        check(
            "Average",
            c,
            &rule(Rule::Fedavg),
            &floats(&by["Average"]),
            mean_tol,
        );
        check(
            "Median",
            c,
            &rule(Rule::Median),
            &floats(&by["Median"]),
            mean_tol,
        );
        check(
            "TrMean",
            c,
            &rule(Rule::TrimmedMean),
            &floats(&by["TrMean"]),
            mean_tol,
        );
        check("MDA", c, &rule(Rule::Mda), &floats(&by["MDA"]), mean_tol);
        check(
            "Meamed",
            c,
            &rule(Rule::Meamed),
            &floats(&by["Meamed"]),
            mean_tol,
        );
        let (monna, _) = monna::nearest_mean(refs[0], &refs, q - f);
        check("MoNNA", c, &monna, &floats(&by["MoNNA"]), mean_tol);

        // Krum's machinery with ByzFL's n - f - 1 neighbours.
        let scores = krum_scores(&refs, q - f - 1);
        let mut order: Vec<usize> = (0..q).collect();
        order.sort_by_key(|&k| (scores[k], k));
        check("Krum", c, refs[order[0]], &floats(&by["Krum"]), float);
        let best: Vec<&[i64]> = order[..q - f].iter().map(|&k| refs[k]).collect();
        check(
            "MultiKrum",
            c,
            &mean(&best),
            &floats(&by["MultiKrum"]),
            mean_tol,
        );

        // The same radius on both sides (the script computes swarmfl's).
        let mut norms: Vec<u128> = refs
            .iter()
            .map(|w| rules::isqrt(rules::squared_distance(w, &current)))
            .collect();
        norms.sort_unstable();
        assert_eq!(
            norms[(q - 1) / 2] as u64,
            case["cc_tau_units"].as_u64().expect("tau"),
            "case {c}: the script's centered-clipping radius is swarmfl's"
        );
        let cc_tol = 3.0 * 2.0 * (len as f64).sqrt() + float;
        check(
            "CenteredClipping",
            c,
            &rule(Rule::CenteredClipping),
            &floats(&by["CenteredClipping"]),
            cc_tol,
        );

        let rho = case["geomed_rate"].as_f64().expect("rate");
        assert!((0.0..1.0).contains(&rho), "case {c}: a contraction rate");
        let gm_tol = 2.5 * (len as f64).sqrt() / (1.0 - rho) + float;
        check(
            "GeometricMedian",
            c,
            &rule(Rule::Geomed),
            &floats(&by["GeometricMedian"]),
            gm_tol,
        );
        checked += 1;
    }
    assert_eq!(checked, cases.len());
}

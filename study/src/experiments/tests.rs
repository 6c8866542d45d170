use super::*;
use swarmfl_core::config::{ByzantineVariant, Config};

#[test]
fn task_lists_have_the_papers_sizes_and_point_major_order() {
    let check = |name: &str, points: usize, runs: u32| {
        let exp = experiment(name).unwrap();
        assert_eq!(exp.points.len(), points, "{name}");
        assert_eq!(exp.runs, runs, "{name}");
        let list = tasks(&exp, exp.runs, &[]);
        assert_eq!(list.len(), points * runs as usize, "{name}");
        for (i, t) in list.iter().enumerate() {
            assert_eq!(t.index, i);
            assert_eq!(t.point_index, i / runs as usize);
            assert_eq!(t.seed, (i % runs as usize) as u64 + 1);
        }
    };
    check("e0-baselines", 9, 5);
    check("e1-expiration", 5, 5);
    check("e1-faulty", 1, 10);
    check("e2-faulty", 8, 20);
    check("e2-malicious", 8, 20);
    check("e3-smart", 8, 18);
    check("e4-benchmark", 3 * 16 * 9, 3);
    check("e4-gate", 3 * 2 * 5, 3);
    check("e5-smart-defence", 39, 3);
    check("e2-malicious-authors", 8, 20);
    check("e3-smart-authors", 8, 18);
    check("e2-malicious-authors-timing", 8, 20);
    check("e3-smart-authors-timing", 8, 18);
    check("e3-smart-authors-code", 8, 18);
    check("e6-scale", 11, 3);
    check("e6-scale-1000", 3, 2);
    assert!(experiment("e4").is_err());
}

/// Each point of an `-authors` experiment is its namesake of the paper's experiment with
/// the authors' contract, and nothing else changed.
#[test]
fn the_authors_experiments_differ_from_the_papers_only_in_the_contract() {
    for (ours, theirs) in [
        ("e2-malicious", "e2-malicious-authors"),
        ("e3-smart", "e3-smart-authors"),
    ] {
        let (a, b) = (experiment(ours).unwrap(), experiment(theirs).unwrap());
        assert_eq!(a.runs, b.runs);
        for (p, q) in a.points.iter().zip(&b.points) {
            assert_eq!((&p.name, p.x), (&q.name, q.x));
            let mine = Config::resolve(Some(&a.preset), None, &p.overrides).unwrap();
            let mut authors = Config::resolve(Some(&b.preset), None, &q.overrides).unwrap();
            assert_ne!(mine.contract, authors.contract, "{theirs} {}", q.name);
            assert_eq!(authors.contract.reward_weights, [1, 1, 1, 1, 1, -1, -1]);
            assert_eq!(
                authors.contract.options(),
                swarmfl_core::config::ContractOptions::authors()
            );
            authors.contract = mine.contract.clone();
            authors.preset = mine.preset.clone();
            assert_eq!(mine, authors, "{theirs} {}", q.name);
        }
    }
}

/// Each point of an `-authors-timing` experiment is its namesake under the authors'
/// contract with the authors' timing, and nothing else changed (`-code` also sets the smart
/// robots' variant).
#[test]
fn the_authors_timing_experiments_differ_from_the_authors_only_in_the_timing() {
    for (theirs, timed, variant) in [
        ("e2-malicious-authors", "e2-malicious-authors-timing", None),
        ("e3-smart-authors", "e3-smart-authors-timing", None),
        (
            "e3-smart-authors",
            "e3-smart-authors-code",
            Some(ByzantineVariant::Authors),
        ),
    ] {
        let (a, b) = (experiment(theirs).unwrap(), experiment(timed).unwrap());
        assert_eq!(a.runs, b.runs);
        for (p, q) in a.points.iter().zip(&b.points) {
            assert_eq!((&p.name, p.x), (&q.name, q.x));
            let mut untimed = Config::resolve(Some(&a.preset), None, &p.overrides).unwrap();
            let t = Config::resolve(Some(&b.preset), None, &q.overrides).unwrap();
            assert_eq!(t.learn.timing, swarmfl_core::config::Timing::Authors);
            untimed.learn.timing = t.learn.timing;
            untimed.preset = t.preset.clone();
            if let (Some(v), true) = (variant, p.x > 0.0) {
                assert_eq!(t.byzantine.variant, v, "{timed} {}", q.name);
                untimed.byzantine.variant = t.byzantine.variant;
            }
            assert_eq!(untimed, t, "{timed} {}", q.name);
        }
    }
}

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
    check("e4-heterogeneity", 5 * 9 * 7, 5);
    check("e5-smart-defence", 39, 3);
    check("e2-malicious-authors", 8, 20);
    check("e3-smart-authors", 8, 18);
    check("e2-malicious-authors-timing", 8, 20);
    check("e3-smart-authors-timing", 8, 18);
    check("e3-smart-authors-code", 8, 18);
    check("e2-malicious-authors-gas", 8, 20);
    check("e3-smart-authors-gas", 8, 18);
    check("e6-scale", 13, 3);
    check("e6-scale-1000", 3, 2);
    check("e6-scale-1000-gossip", 1, 2);
    check("e4-heterogeneity-measure", 10, 3);
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

#[test]
fn the_e4_attacks_are_the_published_twelve() {
    let names: Vec<&str> = E4_ATTACKS.iter().map(|k| k.name()).collect();
    assert_eq!(
        names,
        [
            "faulty",
            "malicious",
            "smart",
            "sign-flip",
            "gaussian",
            "alie",
            "ipm",
            "min-max",
            "mimic",
            "inflate-samples",
            "poison-data",
            "collude"
        ]
    );
    let exp = experiment("e4-robustness").unwrap();
    let attacks: std::collections::BTreeSet<&str> = exp
        .points
        .iter()
        .flat_map(|p| p.tags.iter().filter(|(k, _)| *k == "attack"))
        .map(|(_, v)| v.as_str())
        .filter(|&a| a != "none")
        .collect();
    assert_eq!(attacks.len(), 12);
    assert!(names.iter().all(|n| attacks.contains(n)));
}

/// No two experiments share a name: `experiment` would find the first only.
#[test]
fn experiment_names_are_unique() {
    let names: std::collections::BTreeSet<&str> = EXPERIMENTS.into_iter().collect();
    assert_eq!(names.len(), ALL.len(), "{EXPERIMENTS:?}");
}

#[test]
fn every_point_resolves_to_a_valid_configuration() {
    for name in EXPERIMENTS {
        let exp = experiment(name).unwrap();
        for point in &exp.points {
            let resolved = Config::resolve(Some(&exp.preset), None, &point.overrides);
            let evm = point.overrides.iter().any(|o| o == "contract.engine=evm");
            if evm && !cfg!(feature = "evm") {
                // The `-authors-gas` points: a build without the EVM refuses them, saying how
                // to build one.
                let e = resolved.unwrap_err().to_string();
                assert!(
                    e.contains("contract.engine") && e.contains("--features evm"),
                    "{e}"
                );
                continue;
            }
            let config = resolved.unwrap_or_else(|e| panic!("{name} {}: {e}", point.name));
            if name == "e1-expiration" {
                assert_eq!(config.data.expiration_s, point.x);
            } else if name == "e4-heterogeneity-measure" {
                // x is the alpha's place on the axis; no robot trains.
                let alpha = &point.tags[0].1;
                assert!(point
                    .overrides
                    .contains(&format!("world.home_range.alpha={alpha}")));
                assert_eq!(config.byzantine.count, 0);
            } else if name.starts_with("e6-scale") {
                assert_eq!(f64::from(config.world.robots), point.x);
                let protocol = point.name.split('-').next().unwrap();
                let buffered = config.contract.protocol.name() == "buffered";
                let on_buffers = protocol == "buffered" || protocol == "matched";
                assert_eq!(buffered, on_buffers, "{}", point.name);
                let aggregation = config.learn.aggregation.name();
                match protocol {
                    "matched" | "gossip" => assert_eq!(aggregation, protocol),
                    _ => assert_eq!(aggregation, "chain", "{}", point.name),
                }
                // The paper's training period at every size (issue 56).
                assert_eq!(config.learn.training_period_s, 100.0, "{}", point.name);
            } else {
                assert_eq!(f64::from(config.byzantine.count), point.x);
            }
            if name == "e0-baselines" {
                let aggregation = point.name.split('-').next().unwrap();
                assert_eq!(config.learn.aggregation.name(), aggregation);
            }
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

/// Every `e4-heterogeneity` point resolves, sets the alpha its name says, and at alpha `inf`
/// is its `e4-benchmark` (or, gated, `e4-gate`) avoidance namesake: the same configuration, so
/// the same runs at the same seeds. Byzantine 0 runs no attack, 3 and 5 every attack.
#[test]
fn the_heterogeneity_grid_sets_alpha_and_at_inf_is_the_benchmarks_avoidance_column() {
    let exp = experiment("e4-heterogeneity").unwrap();
    let bench = experiment("e4-benchmark").unwrap();
    let gate = experiment("e4-gate").unwrap();
    let mut namesakes = 0;
    for p in &exp.points {
        let config = Config::resolve(Some(&exp.preset), None, &p.overrides)
            .unwrap_or_else(|e| panic!("{}: {e:#}", p.name));
        let alpha = p.tag("alpha").unwrap();
        let want = if alpha == "inf" {
            f64::INFINITY
        } else {
            alpha.parse().unwrap()
        };
        assert_eq!(config.world.home_range.alpha, want, "{}", p.name);
        assert_eq!(config.run.duration_s, 5000.0);
        assert_eq!(config.byzantine.count, p.x as u32);
        assert_eq!(p.x == 0.0, p.tag("attack").unwrap() == "none", "{}", p.name);
        let Some(rest) = p.name.strip_prefix("alpha-inf--") else {
            continue;
        };
        let theirs = format!("avoidance--{rest}");
        let (grid, preset) = if rest.starts_with("gate+") {
            (&gate, &gate.preset)
        } else {
            (&bench, &bench.preset)
        };
        let Some(q) = grid.points.iter().find(|q| q.name == theirs) else {
            continue;
        };
        let mut other = Config::resolve(Some(preset), None, &q.overrides).unwrap();
        other.preset = config.preset.clone();
        assert_eq!(config, other, "{} against {theirs}", p.name);
        namesakes += 1;
    }
    assert_eq!(exp.points.len(), 5 * 9 * (1 + 2 * 3));
    // Eight rules in e4-benchmark (7 points each) and the gated median at 0 and 5 in e4-gate.
    assert_eq!(namesakes, 8 * 7 + 4);
}

/// Each point of an `-authors-gas` experiment is its `-authors-timing` namesake with the EVM
/// engine and the authors' gas limits, and nothing else changed (compared as overrides: a
/// build without the evm feature refuses the engine).
#[test]
fn the_authors_gas_experiments_add_only_the_evm_and_its_gas_limits() {
    for (timed, gas) in [
        ("e2-malicious-authors-timing", "e2-malicious-authors-gas"),
        ("e3-smart-authors-timing", "e3-smart-authors-gas"),
    ] {
        let (a, b) = (experiment(timed).unwrap(), experiment(gas).unwrap());
        assert_eq!((a.runs, &a.preset), (b.runs, &b.preset));
        assert_eq!(a.points.len(), b.points.len());
        for (p, q) in a.points.iter().zip(&b.points) {
            assert_eq!((&p.name, p.x), (&q.name, q.x));
            let mut want = p.overrides.clone();
            want.extend(AUTHORS_GAS.map(String::from));
            assert_eq!(q.overrides, want, "{gas} {}", q.name);
        }
    }
}

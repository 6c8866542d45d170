//! `swarmfl bench scale --json` at two tiny swarms: every size ran in its own child process and
//! reports its times, per-part costs and peak RSS as positive numbers (no timing is asserted).

use std::process::Command;

#[test]
fn bench_scale_reports_every_size_with_positive_figures() {
    let out = Command::new(env!("CARGO_BIN_EXE_swarmfl"))
        .args([
            "bench",
            "scale",
            "--robots",
            "15,30",
            "--duration-s",
            "20",
            "--seed",
            "3",
            "--set",
            "contract.protocol=buffered",
            "--json",
        ])
        .output()
        .expect("running swarmfl");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(report["duration_s"], 20.0);
    assert_eq!(report["seed"], 3);
    assert_eq!(report["overrides"][0], "contract.protocol=buffered");
    // Without 60 robots, the smallest size is the reference.
    assert_eq!(
        (
            report["reference_robots"].as_u64(),
            report["largest_robots"].as_u64()
        ),
        (Some(15), Some(30))
    );
    let sizes = report["sizes"].as_array().expect("sizes");
    assert_eq!(sizes.len(), 2);
    for (size, (robots, side_m)) in sizes.iter().zip([(15u64, 5.0f64), (30, 50f64.sqrt())]) {
        assert_eq!(size["robots"].as_u64(), Some(robots));
        // The paper's density: 15 robots per 25 m^2.
        let side = size["arena_side_m"].as_f64().unwrap();
        assert!((side - side_m).abs() < 1e-9, "{side} m for {robots} robots");
        assert_eq!(size["cylinders"].as_u64(), Some(robots / 3));
        for key in ["wall_s", "cpu_s", "peak_rss_kib"] {
            let v = size[key].as_f64().unwrap_or(f64::NAN);
            assert!(v > 0.0, "{robots} robots: {key} = {v}");
        }
        for part in ["world", "ledger", "checkpoint"] {
            let v = size["timing"][format!("{part}_s")]
                .as_f64()
                .unwrap_or(f64::NAN);
            assert!(v > 0.0, "{robots} robots: timing {part}_s = {v}");
            let cost = size["us_per_robot_sim_s"][format!("{part}_cpu")]
                .as_f64()
                .unwrap_or(f64::NAN);
            assert!(cost >= 0.0, "{robots} robots: {part} cost {cost}");
        }
        assert!(size["records"].as_u64().unwrap() > 0);
        // The learning figures: the held-out loss of the genesis model, tokens conserved.
        assert!(size["heldout_genesis"].as_f64().unwrap() > 0.0);
        assert_eq!(size["tokens_conserved"], true);
        assert!(size["model_versions"].as_u64().is_some());
    }
    for key in ["wall", "cpu", "world", "ledger"] {
        let r = report["ratio_largest_to_reference"][key]
            .as_f64()
            .unwrap_or(f64::NAN);
        assert!(r.is_finite() && r > 0.0, "ratio {key} = {r}");
    }
    assert!(
        ["world", "ledger", "learning"].contains(&report["fastest_growing_part"].as_str().unwrap())
    );
}

#[test]
fn bench_scale_refuses_bad_sizes_and_foreign_options() {
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_swarmfl"))
            .args(args)
            .output()
            .expect("running swarmfl");
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (code, err) = run(&["bench", "scale", "--robots", "15,x"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--robots: `x` is not a swarm size"), "{err}");
    // The old spelling is an alias of `--duration`, with `run.duration_s`'s range.
    let (code, err) = run(&["bench", "scale", "--robots", "15", "--duration-s", "0"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--duration <SECONDS>"), "{err}");
    assert!(err.contains("0 seconds is out of range"), "{err}");
    // The benchmark's own keys, and bad overrides, are refused before any run.
    let (code, err) = run(&["bench", "scale", "--set", "world.robots=3"]);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("`world.robots` is set by `bench scale` itself"),
        "{err}"
    );
    let (code, err) = run(&["bench", "scale", "--set", "contract.protocol=sideways"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("contract.protocol"), "{err}");
    let (code, err) = run(&["bench", "train", "--seed", "2"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("belong to `bench scale` only"), "{err}");
    let (code, err) = run(&["bench", "train", "--robots", "15"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("belong to `bench scale` only"), "{err}");
}

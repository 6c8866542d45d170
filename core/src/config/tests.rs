use super::*;

#[test]
fn every_preset_is_valid_and_round_trips_through_toml() {
    for preset in Preset::ALL {
        let config = preset.config();
        config
            .validate()
            .unwrap_or_else(|e| panic!("{preset}: {e}"));
        let back: Config = toml::from_str(&config.to_toml()).unwrap();
        assert_eq!(back, config, "{preset}");
    }
}

/// `contract.rule` is listed in every resolved configuration; a configuration written
/// before rules existed (no `rule`, no `assumed_f`) reads as `paper`, and
/// `security = false` still means `fedavg`.
#[test]
fn the_rule_is_listed_and_old_configurations_read() {
    let paper = Preset::Paper.config();
    assert!(paper.to_toml().contains("rule = \"paper\""));
    assert_eq!(paper.flat_values()["contract.rule"], "\"paper\"");
    let mut old: toml::Table = toml::from_str(&paper.to_toml()).unwrap();
    let contract = old["contract"].as_table_mut().unwrap();
    contract.remove("rule");
    contract.remove("assumed_f");
    contract.insert("security".into(), toml::Value::Boolean(false));
    let text = toml::to_string(&old).unwrap();
    let c = Config::from_toml_str(&text, "old.toml").unwrap();
    assert_eq!(c.contract.rule, Rule::Paper);
    assert_eq!(c.rule(), Rule::Fedavg);
    let mut krum = Preset::Paper.config();
    krum.set("contract.rule=krum").unwrap();
    krum.validate().unwrap();
    krum.set("contract.assumed_f=3").unwrap();
    let e = krum.validate().unwrap_err().to_string();
    assert!(
        e.contains("contract.assumed_f") && e.contains("krum"),
        "{e}"
    );
}

#[test]
fn paper_quorum_is_seven() {
    assert_eq!(Preset::Paper.config().quorum(), 7);
    assert_eq!(
        Preset::Paper.config().reward_weights(),
        vec![1, 1, 1, 1, 1, -1, -1]
    );
}

#[test]
fn overrides_set_nested_fields_and_coerce_integers_to_floats() {
    let c = Config::resolve(
        Some("smoke"),
        None,
        &[
            "world.rab_range_m=3".into(),
            "byzantine.kind=faulty".into(),
            "byzantine.count=2".into(),
        ],
    )
    .unwrap();
    assert_eq!(c.world.rab_range_m, 3.0);
    assert_eq!(c.byzantine.kind, ByzantineKind::Faulty);
    assert_eq!(c.byzantine.count, 2);
}

fn check_err(overrides: &[&str], expect: &str) {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let err = Config::resolve(None, None, &overrides)
        .unwrap_err()
        .to_string();
    assert!(err.contains(expect), "error {err:?} lacks {expect:?}");
}

#[test]
fn errors_name_the_key_the_value_and_what_is_allowed() {
    check_err(
        &["world.robtos=3"],
        "unknown configuration key `world.robtos`",
    );
    check_err(&["world.robtos=3"], "rab_range_m");
    check_err(
        &["world.robots=many"],
        "`world.robots`: value `many` has the wrong type; expected an integer",
    );
    check_err(
        &["world.robots=0"],
        "`world.robots`: value 0 is out of range; allowed: an integer in [1, 10000]",
    );
    check_err(&["learn.dropout=1.5"], "learn.dropout");
    check_err(&["byzantine.kind=evil"], "byzantine.kind");
    check_err(&["byzantine.kind=faulty"], "byzantine.count");
    // A plug-in attack with no robots to run it: the Python call and the key, not `--set`.
    check_err(
        &["byzantine.kind=plugin", "byzantine.plugin=sign_flip"],
        "the plug-in attack `sign_flip` (byzantine.plugin) runs on byzantine.count robots and \
         none is given; give the count with the attack, e.g. swarmfl.run(..., \
         attack=MyAttack(), set={\"byzantine.count\": 3}) in Python",
    );
    check_err(&["noequals"], "expected key.path=value");
    check_err(
        &["world.robots.x=1"],
        "unknown configuration key `world.robots.x`; `world.robots` is a value, not a table",
    );
    check_err(
        &["preset=../../etc"],
        "`preset`: value \"../../etc\" is out of range; allowed: one of paper, paper-text, reference",
    );
    let err = Config::resolve(Some("papr"), None, &[])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("unknown preset \"papr\"") && err.contains("e3-smart"),
        "{err}"
    );
}

/// `contract.engine = evm` runs contracts/SwarmFL.sol, the paper's contract with security
/// on or off: every other rule, and the round deadline it lacks, are refused with the key,
/// the value and the fix; native runs keep them.
#[cfg(feature = "evm")]
#[test]
fn the_evm_engine_refuses_what_the_solidity_contract_lacks() {
    for rule in Rule::ALL {
        let set = |engine: &str| {
            Config::resolve(
                None,
                None,
                &[
                    format!("contract.rule={}", rule.name()),
                    format!("contract.engine={engine}"),
                ],
            )
        };
        set("native").unwrap_or_else(|e| panic!("{}: {e}", rule.name()));
        match (rule, set("evm")) {
            (Rule::Paper | Rule::Fedavg, got) => {
                got.unwrap_or_else(|e| panic!("{}: {e}", rule.name()));
            }
            (_, Ok(_)) => panic!("{} accepted under evm", rule.name()),
            (_, Err(e)) => {
                let e = e.to_string();
                assert!(
                    e.contains(&format!("`contract.rule`: value {}", rule.name()))
                        && e.contains("contract.engine = evm")
                        && e.contains("set contract.engine = native"),
                    "{e}"
                );
            }
        }
    }
    // Security off is the fedavg rule, which the contract implements.
    Config::resolve(
        None,
        None,
        &[
            "contract.engine=evm".into(),
            "contract.security=false".into(),
        ],
    )
    .unwrap();
    // The round deadline and the claim bound are in the Solidity contract too (issue 37).
    Config::resolve(
        None,
        None,
        &[
            "contract.engine=evm".into(),
            "contract.round_timeout_s=300".into(),
            "contract.max_claimed_samples=100".into(),
        ],
    )
    .unwrap();
}

/// Without the `evm` feature, `contract.engine = evm` is refused with the command that
/// builds the engine; `native` still runs.
#[cfg(not(feature = "evm"))]
#[test]
fn the_evm_engine_names_the_feature_in_a_build_without_it() {
    check_err(
        &["contract.engine=evm"],
        "`contract.engine`: value evm is out of range; allowed: native in this build of \
         swarmfl, which was built without the EVM engine (cargo feature `evm`, off by \
         default); rebuild with `cargo build --release -p replay-cli --features evm`",
    );
    Config::resolve(None, None, &["contract.engine=native".into()]).unwrap();
}

/// The authors' variant options describe the paper's contract: a robust rule would ignore
/// them, so setting one with it is refused, naming the option.
#[test]
fn variant_options_are_refused_with_a_robust_rule() {
    check_err(
        &["contract.rule=median", "contract.median=mean"],
        "`contract.median`: value \"mean\" is out of range; allowed: its default with \
         contract.rule = median",
    );
    check_err(
        &[
            "contract.rule=krum",
            "contract.reward_weights=[5, 4, 3, 2, 1, -1, -2]",
        ],
        "`contract.reward_weights`: value [5, 4, 3, 2, 1, -1, -2]",
    );
    check_err(
        &["contract.rule=krum", "contract.pool=round"],
        "remove `contract.pool`, or set contract.rule = paper",
    );
    for rule in ["paper", "fedavg"] {
        Config::resolve(
            None,
            None,
            &[
                format!("contract.rule={rule}"),
                "contract.median=mean".into(),
                "contract.pool=round".into(),
                "contract.reward_weights=[5, 4, 3, 2, 1, -1, -2]".into(),
            ],
        )
        .unwrap_or_else(|e| panic!("{rule}: {e}"));
    }
}

#[test]
fn a_file_overlays_the_preset_and_names_itself_in_errors() {
    let dir = std::env::temp_dir().join(format!("swarmfl-config-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("good.toml");
    std::fs::write(&good, "preset = \"reference\"\n[world]\nrobots = 20\n").unwrap();
    let c = Config::resolve(None, Some(&good), &[]).unwrap();
    assert_eq!(
        (c.world.robots, c.world.rab_range_m, c.preset.as_str()),
        (20, 2.0, "reference")
    );
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[world]\nrobots = 20\nspeed = 3\n").unwrap();
    let err = Config::resolve(None, Some(&bad), &[])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("world.speed") && err.contains("bad.toml"),
        "{err}"
    );
    let broken = dir.join("broken.toml");
    std::fs::write(&broken, "[world\nrobots = 20\n").unwrap();
    let err = Config::resolve(None, Some(&broken), &[])
        .unwrap_err()
        .to_string();
    assert!(err.contains("broken.toml") && err.contains("line"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn small_swarms_and_long_ticks_derive_what_the_user_did_not_set() {
    for robots in 1..=5u32 {
        let c = Config::resolve(Some("smoke"), None, &[format!("world.robots={robots}")])
            .unwrap_or_else(|e| panic!("{robots} robots: {e}"));
        assert_eq!(
            c.contract.penalised_ranks,
            c.quorum() - 1,
            "{robots} robots"
        );
        assert!(c.reward_weights()[0] == 1);
    }
    // The paper's swarm keeps the paper's ranks: derivation changes nothing that validates.
    let paper = Config::resolve(None, None, &["world.robots=15".into()]).unwrap();
    assert_eq!(paper, Preset::Paper.config());
    let c = Config::resolve(Some("smoke"), None, &["run.tick_s=10".into()]).unwrap();
    assert_eq!(c.world.peer_refresh_s, 10.0);
    let c = Config::resolve(None, None, &["world.peer_refresh_s=2".into()]).unwrap();
    assert_eq!(c.world.peer_refresh_s, 2.0);
    // What the user set is never changed: the error names their own key.
    check_err(
        &["world.robots=5", "contract.penalised_ranks=2"],
        "`contract.penalised_ranks`: value 2 is out of range",
    );
    check_err(
        &["run.tick_s=1", "world.peer_refresh_s=0.5"],
        "`world.peer_refresh_s`: value 0.5",
    );
    // A preset value that conflicts with the user's and cannot be derived names both.
    check_err(
        &["data.input_waypoints=80"],
        "you did not set `data.target_waypoints` (preset `paper` gives it), but it no \
         longer fits what you set (data.input_waypoints)",
    );
}

#[test]
fn text_parses_like_a_file_and_names_its_source() {
    let c = Config::from_toml_str("preset = \"smoke\"\n[world]\nrobots = 12\n", "mine").unwrap();
    assert_eq!((c.world.robots, c.preset.as_str()), (12, "smoke"));
    let paper = Config::from_toml_str("", "empty").unwrap();
    assert_eq!(paper, Preset::Paper.config());
    for (text, expect) in [
        ("[world\n", "invalid configuration in mine"),
        ("[world]\nrobots = \"x\"\n", "`world.robots (in mine)`"),
        ("preset = 3\n", "`preset (in mine)`"),
        ("preset = \"nope\"\n", "unknown preset \"nope\""),
        (
            "[world]\nrobots = 0\n",
            "`world.robots`: value 0 is out of range",
        ),
    ] {
        let err = Config::from_toml_str(text, "mine").unwrap_err().to_string();
        assert!(err.contains(expect), "{text:?}: {err:?} lacks {expect:?}");
    }
}

/// Every enum with a hand-written `name()` and an `ALL` list: `name()` is the serde name that
/// configurations are written with, so the two cannot drift apart.
#[test]
fn hand_written_names_are_the_serde_names() {
    fn check<T: serde::Serialize + std::fmt::Debug>(all: &[T], name: impl Fn(&T) -> &'static str) {
        for variant in all {
            let serde_name = serde_json::to_value(variant).unwrap();
            assert_eq!(serde_name.as_str(), Some(name(variant)), "{variant:?}");
        }
    }
    check(&Rule::ALL, |r| r.name());
    check(&Defence::ALL, |d| d.name());
    check(&ByzantineKind::ALL, |k| k.name());
    check(&LedgerBehaviour::ALL, |b| b.name());
}

/// The round deadline and the claim bound are on in every preset; a recorded configuration
/// without the keys (a log header of an older build) reads as no deadline and the derived
/// bound, which is what re-simulates those records; a bad value names the key.
#[test]
fn every_preset_has_a_deadline_and_the_derived_claim_bound() {
    for preset in Preset::ALL {
        let c = preset.config();
        assert_eq!(
            c.contract.round_timeout_s,
            crate::config::DEFAULT_ROUND_TIMEOUT_S,
            "{}",
            preset.name()
        );
        assert_eq!(c.contract.max_claimed_samples, 0, "{}", preset.name());
    }
    let text = Preset::Paper.config().to_toml();
    let old: String = text
        .lines()
        .filter(|l| !l.starts_with("max_claimed_samples") && !l.starts_with("round_timeout_s"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert_ne!(old, text);
    let read = crate::config::parse_config(&old, "an old header").unwrap();
    assert_eq!(
        read.contract.round_timeout_s, 0.0,
        "old records had no deadline"
    );
    assert_eq!(read.contract.max_claimed_samples, 0, "the derived bound");
    check_err(
        &["contract.max_claimed_samples=4294967296"],
        "`contract.max_claimed_samples`: value 4294967296 is out of range",
    );
    let c = Config::resolve(None, None, &["contract.max_claimed_samples=500".into()]).unwrap();
    assert_eq!(c.contract.max_claimed_samples, 500);
    // Baselines have no contract: the defaults pass, an explicit bound or deadline is refused.
    Config::resolve(None, None, &["learn.aggregation=gossip".into()]).unwrap();
    check_err(
        &[
            "learn.aggregation=central",
            "contract.max_claimed_samples=500",
        ],
        "`contract.max_claimed_samples`: value 500 is out of range; allowed: 0 (derived",
    );
}

#[test]
fn a_typo_in_a_choice_says_the_value_is_unknown_lists_the_choices_and_suggests_the_nearest() {
    let err = Config::resolve(Some("smoke"), None, &["contract.rule=krumm".into()])
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("configuration key `contract.rule`: unknown value `krumm`; did you mean `krum`?; the choices are: `fedavg`, `paper`, `krum`,"),
        "{err}"
    );
    assert!(!err.contains("wrong type"), "{err}");
    // Nothing close: the choices without a guess.
    let err = Config::resolve(Some("smoke"), None, &["byzantine.kind=zzzzzzzz".into()])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("unknown value `zzzzzzzz`; the choices are: `none`, `faulty`"),
        "{err}"
    );
}

#[test]
fn a_value_under_a_table_the_user_set_is_theirs_and_the_message_is_said_once() {
    // The whole list was set, so the robot inside it was set too: the plain range error.
    let err = Config::resolve(
        Some("smoke"),
        None,
        &["faults.crashes=[{robot=30,start_s=50,end_s=120}]".into()],
    )
    .unwrap_err();
    let text = err.to_string();
    assert!(
        text.starts_with("configuration key `faults.crashes[0].robot`: value 30 is out of range"),
        "{text}"
    );
    assert!(!text.contains("you did not set"), "{text}");
    // A value from the preset that conflicts: named, with the range error once, and no
    // `source()` for an error-chain printer to repeat.
    let err = Config::resolve(Some("smoke"), None, &["byzantine.kind=faulty".into()]).unwrap_err();
    let text = err.to_string();
    assert_eq!(text.matches("is out of range").count(), 1, "{text}");
    assert!(std::error::Error::source(&err).is_none());
    // Configuration names, not Rust's.
    assert!(
        text.contains("byzantine.kind is \"faulty\", byzantine.ledger is \"honest\""),
        "{text}"
    );
}

#[test]
fn keys_added_later_leave_the_canonical_text_unchanged_at_their_default() {
    // A configuration that leaves them at their defaults has the text it had before they
    // existed (so its log hash chain too), yet `swarmfl config` shows them and `--set` reaches
    // them. `paper` (hence every preset) now sets two of them, so they are written.
    let paper = Config::resolve(Some("paper"), None, &[]).unwrap().to_toml();
    assert!(paper.contains("rab_robot_occlusion = true"), "{paper}");
    assert!(paper.contains("window_rule = \"confirmed\""), "{paper}");
    assert!(paper.contains("avoidance = \"epuck\""), "{paper}");
    assert!(paper.contains("slide_on_contact = true"), "{paper}");
    let smoke = Config::resolve(
        Some("smoke"),
        None,
        &[
            "world.rab_robot_occlusion=false".into(),
            "data.window_rule=contiguous".into(),
            "world.avoidance=turn".into(),
            "world.slide_on_contact=false".into(),
        ],
    )
    .unwrap();
    let text = smoke.to_toml();
    let full = smoke.to_toml_full();
    for key in [
        "world.rab_robot_occlusion",
        "world.behaviour",
        "world.mixed",
        "world.flocking",
        "world.foraging",
        "world.avoidance",
        "world.slide_on_contact",
        "data.window_rule",
        "contract.block_gas_limit",
        "contract.gas_limit",
        "contract.gas_margin",
        "contract.gas_estimate_state",
        "contract.gas_recommit_s",
        "contract.preaggregators",
        "contract.bucket_size",
        "contract.clip_radius",
        "byzantine.search_evals",
        "byzantine.plugin",
        "contract.rule_plugin",
        "contract.rank_order",
        "contract.outlier_rule",
        "contract.outlier_factor",
        "contract.outlier_window",
        "contract.outlier_cap",
    ] {
        let leaf = key.rsplit('.').next().unwrap();
        assert!(!text.contains(&format!("{leaf} =")), "{key} in {text}");
        assert!(!text.contains(&format!("[{key}]")), "{key} in {text}");
        assert!(
            full.contains(&format!("{leaf} =")) || full.contains(&format!("[{key}]")),
            "{key} missing from the full text {full}"
        );
    }
    assert!(full.contains("window_rule = \"contiguous\""));
    assert!(
        full.contains("block_gas_limit = 2533274790395904"),
        "{full}"
    );
    // The full text leaves the recorded one as it was.
    assert_eq!(smoke.to_toml(), text);
    let back: Config = toml::from_str(&text).unwrap();
    assert_eq!(back, smoke);
    let flocking =
        Config::resolve(Some("smoke"), None, &["world.behaviour=flocking".into()]).unwrap();
    assert!(flocking.to_toml().contains("behaviour = \"flocking\""));
    let back: Config = toml::from_str(&flocking.to_toml()).unwrap();
    assert_eq!(back, flocking);
}

#[test]
fn bad_behaviour_settings_are_refused_naming_the_key() {
    let err = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        Config::resolve(None, None, &sets).unwrap_err().to_string()
    };
    let e = err(&["world.behaviour=dance"]);
    assert!(
        e.contains("world.behaviour") && e.contains("flocking"),
        "{e}"
    );
    let e = err(&["world.behaviour=mixed", "world.mixed.avoidance=0.5"]);
    assert!(e.contains("world.mixed") && e.contains("sum to 1"), "{e}");
    let e = err(&["world.behaviour=foraging", "world.foraging.nest_x_m=2.3"]);
    assert!(
        e.contains("world.foraging.nest_x_m") && e.contains("inside the arena"),
        "{e}"
    );
    let e = err(&[
        "world.behaviour=mixed",
        "world.mixed.per_robot=[\"flocking\"]",
    ]);
    assert!(
        e.contains("world.mixed.per_robot") && e.contains("15"),
        "{e}"
    );
    let e = err(&["world.mixed.per_robot=[\"flocking\"]"]);
    assert!(e.contains("world.mixed.per_robot"), "{e}");
    // Accepted: shares that sum to 1, and a foraging-free swarm ignores the nest.
    let ok = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        Config::resolve(None, None, &sets).unwrap()
    };
    ok(&[
        "world.behaviour=mixed",
        "world.mixed.avoidance=0.5",
        "world.mixed.flocking=0.5",
        "world.mixed.foraging=0",
    ]);
    ok(&["world.behaviour=flocking", "world.foraging.nest_x_m=9"]);
    // The place rule (`world.mixed.assign`): a known value, a mixed swarm, no per-robot list,
    // our own foragers, an arena that holds Flow-FL's layout.
    let e = err(&["world.behaviour=mixed", "world.mixed.assign=random"]);
    assert!(
        e.contains("world.mixed.assign") && e.contains("share") && e.contains("place"),
        "{e}"
    );
    let e = err(&["world.mixed.assign=place", "world.arena_side_m=5.9"]);
    assert!(
        e.contains("world.mixed.assign") && e.contains("world.behaviour=mixed"),
        "{e}"
    );
    let place = ["world.behaviour=mixed", "world.mixed.assign=place"];
    let e = err(&place);
    assert!(
        e.contains("world.arena_side_m") && e.contains("world.mixed.assign"),
        "{e}"
    );
    let e = err(&[
        place[0],
        place[1],
        "world.arena_side_m=5.9",
        "world.foraging.rule=flowfl",
    ]);
    assert!(
        e.contains("world.foraging.rule") && e.contains("simple"),
        "{e}"
    );
    let per_robot = format!("world.mixed.per_robot={:?}", vec!["flocking"; 15]);
    let e = err(&[place[0], place[1], "world.arena_side_m=5.9", &per_robot]);
    assert!(e.contains("world.mixed.per_robot"), "{e}");
    let e = err(&[place[0], place[1], "world.arena_side_m=nan"]);
    assert!(e.contains("world.arena_side_m"), "{e}");
    let c = ok(&[place[0], place[1], "world.arena_side_m=5.9"]);
    assert_eq!(c.world.mixed.assign, MixedAssign::Place);
    // The e-puck's avoidance weighs its eight sensors; an unknown rule names its key.
    let e = err(&["world.avoidance=epuck", "world.proximity_sensors=6"]);
    assert!(
        e.contains("world.proximity_sensors") && e.contains("world.avoidance"),
        "{e}"
    );
    let e = err(&["world.avoidance=swerve"]);
    assert!(e.contains("world.avoidance") && e.contains("epuck"), "{e}");
    let e = err(&["world.slide_on_contact=3"]);
    assert!(e.contains("world.slide_on_contact"), "{e}");
    let c = ok(&["world.avoidance=epuck", "world.slide_on_contact=true"]);
    assert!(c.to_toml().contains("avoidance = \"epuck\""));
    assert!(c.to_toml().contains("slide_on_contact = true"));
    // Flow-FL's Khepera rule reads four of eight sensors by index.
    let e = err(&["world.avoidance=khepera", "world.proximity_sensors=6"]);
    assert!(
        e.contains("world.proximity_sensors") && e.contains("khepera"),
        "{e}"
    );
    let flowfl = Preset::Flowfl.config().to_toml();
    assert!(flowfl.contains("avoidance = \"khepera\""), "{flowfl}");
    assert!(flowfl.contains("slide_on_contact = true"), "{flowfl}");
}

#[test]
fn a_plugin_rule_needs_its_name_and_no_preaggregators() {
    let set = |o: &[&str]| {
        let o: Vec<String> = o.iter().map(|s| s.to_string()).collect();
        Config::resolve(Some("smoke"), None, &o)
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    assert!(set(&[
        "contract.rule=\"plugin\"",
        "contract.rule_plugin=\"np_median\""
    ])
    .is_ok());
    let e = set(&["contract.rule=\"plugin\""]).unwrap_err();
    assert!(
        e.contains("contract.rule_plugin") && e.contains("swarmfl.run(..., rule="),
        "{e}"
    );
    let e = set(&["contract.rule_plugin=\"x\""]).unwrap_err();
    assert!(e.contains("empty unless contract.rule = \"plugin\""), "{e}");
    let e = set(&[
        "contract.rule=\"plugin\"",
        "contract.rule_plugin=\"x\"",
        "contract.preaggregators=[\"nnm\"]",
    ])
    .unwrap_err();
    assert!(e.contains("contract.preaggregators"), "{e}");
    // The name is a plain word: it is recorded and matched against the offered rules.
    let e = set(&["contract.rule=\"plugin\"", "contract.rule_plugin=\"a b\""]).unwrap_err();
    assert!(e.contains("1 to 100 of"), "{e}");
}

#[test]
fn rank_order_is_left_out_of_the_options_encoding_at_its_default() {
    // The authors' options are encoded in their genesis parameters: the new key must not
    // change those bytes, and `nearest` must show.
    let authors = rmp_serde::to_vec(&ContractOptions::authors()).unwrap();
    let toml = toml::to_string(&ContractOptions::authors()).unwrap();
    assert!(!toml.contains("rank_order"), "{toml}");
    let nearest = ContractOptions {
        rank_order: RankOrder::Nearest,
        ..ContractOptions::authors()
    };
    let encoded = rmp_serde::to_vec(&nearest).unwrap();
    assert!(encoded.len() > authors.len());
    assert_ne!(nearest, ContractOptions::authors());
    let back: ContractOptions = rmp_serde::from_slice(&authors).unwrap();
    assert_eq!(back, ContractOptions::authors());
    let back: ContractOptions = rmp_serde::from_slice(&encoded).unwrap();
    assert_eq!(back.rank_order, RankOrder::Nearest);
    // Set through `--set`, and refused with a robust rule like the other options.
    let c = Config::resolve(
        Some("e3-smart"),
        None,
        &["contract.rank_order=nearest".into()],
    )
    .unwrap();
    assert_eq!(c.contract.options().rank_order, RankOrder::Nearest);
    assert!(c.to_toml().contains("rank_order = \"nearest\""));
    let err = Config::resolve(
        Some("smoke"),
        None,
        &[
            "contract.rule=median".into(),
            "contract.rank_order=nearest".into(),
        ],
    )
    .unwrap_err();
    assert!(err.to_string().contains("contract.rank_order"), "{err}");
}

#[cfg(feature = "evm")]
#[test]
fn the_evm_engine_refuses_the_nearest_rank_order() {
    let err = Config::resolve(
        Some("smoke"),
        None,
        &[
            "contract.engine=evm".into(),
            "contract.rank_order=nearest".into(),
        ],
    )
    .unwrap_err();
    assert!(err.to_string().contains("ranks around"), "{err}");
}

#[test]
fn the_flowfl_experiments_are_presets_and_bad_foraging_input_names_its_key() {
    // Every preset made before the flowfl-* experiments keeps its recorded text: the new
    // foraging keys stay out of it at their defaults.
    for preset in Preset::ALL {
        let text = preset.config().to_toml();
        let counts_per_robot = matches!(preset, Preset::FlowflForaging | Preset::FlowflMixed);
        assert_eq!(
            text.contains("food_per_robot"),
            counts_per_robot,
            "{preset}: {text}"
        );
        assert_eq!(
            text.contains("rule = \"flowfl\""),
            preset == Preset::FlowflForaging,
            "{preset}"
        );
        // Only Flow-FL's mixed experiment assigns behaviours by place; every other preset
        // keeps its text without the key.
        assert_eq!(
            text.contains("assign ="),
            preset == Preset::FlowflMixed,
            "{preset}: {text}"
        );
    }
    let mixed = Preset::FlowflMixed.config();
    assert_eq!(mixed.world.mixed.assign, MixedAssign::Place);
    assert!(mixed.to_toml().contains("assign = \"place\""));
    let foraging = Preset::FlowflForaging.config();
    assert_eq!(foraging.world.foraging.rule, ForagingRule::Flowfl);
    assert_eq!(foraging.world.foraging.food_count(60), 120);
    assert_eq!((foraging.world.cylinders, foraging.world.boxes), (0, 0));
    assert!(foraging.to_toml().contains("rule = \"flowfl\""));
    assert_eq!(Preset::FlowflMixed.config().world.arena_side_m, 5.9);
    assert_eq!(
        Preset::FlowflFlocking.config().world.cruise_speed_mps,
        0.025
    );
    for b in Behaviour::ALL {
        let p = Preset::flowfl_experiment(b);
        let c = p.config();
        assert!(p == Preset::Flowfl || c.world.behaviour == b, "{p}");
        c.validate().unwrap();
    }
    let err = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        Config::resolve(Some("flowfl-foraging"), None, &sets)
            .unwrap_err()
            .to_string()
    };
    let e = err(&["world.arena_side_m=3"]);
    assert!(
        e.contains("world.arena_side_m") && e.contains("flowfl"),
        "{e}"
    );
    let e = err(&["run.tick_s=0.05"]);
    assert!(e.contains("run.tick_s") && e.contains("0.1"), "{e}");
    let e = err(&["world.foraging.food_per_robot=1000"]);
    assert!(e.contains("world.foraging.food_per_robot"), "{e}");
    let e = err(&["world.foraging.rule=greedy"]);
    assert!(
        e.contains("world.foraging.rule") && e.contains("simple"),
        "{e}"
    );
    let e = err(&[
        "world.foraging.food_per_robot=0",
        "world.foraging.food_sources=0",
    ]);
    assert!(e.contains("world.foraging.food_sources"), "{e}");
}

#[test]
fn the_threshold_gate_needs_a_robust_rule_and_stays_out_of_records_when_off() {
    let set = |o: &[&str]| {
        let o: Vec<String> = o.iter().map(|s| s.to_string()).collect();
        Config::resolve(Some("smoke"), None, &o).map_err(|e| e.to_string())
    };
    let gated = set(&["contract.rule=\"median\"", "contract.threshold_gate=true"]).unwrap();
    assert!(gated.contract.threshold_gate);
    assert!(gated.to_toml().contains("threshold_gate = true"));
    for rule in ["paper", "fedavg"] {
        let e = set(&[
            &format!("contract.rule=\"{rule}\""),
            "contract.threshold_gate=true",
        ])
        .unwrap_err();
        assert!(
            e.contains("contract.threshold_gate") && e.contains("robust rule"),
            "{rule}: {e}"
        );
    }
    let off = set(&["contract.rule=\"median\""]).unwrap();
    assert!(
        !off.to_toml().contains("threshold_gate"),
        "off, the key is not recorded"
    );
}

/// The message of `--set assignment` on the smoke preset.
fn set_err(assignment: &str) -> String {
    Config::resolve(Some("smoke"), None, &[assignment.to_string()])
        .unwrap_err()
        .to_string()
}

/// Each message says the key, the value, what is expected and the fix, in the user's words.
#[test]
fn rough_values_get_messages_in_the_users_terms() {
    // A negative count: the key's range, not serde's `expected u32`.
    assert_eq!(
        set_err("world.robots=-3"),
        "configuration key `world.robots`: value -3 is out of range; allowed: an integer in \
         [1, 10000]"
    );
    // A list left open: not a string of the wrong type, but TOML that does not parse.
    let e = set_err(r#"faults.partitions=[{kind="split""#);
    assert!(
        e.starts_with(r#"invalid override `faults.partitions=[{kind="split"`: the value `[{kind="split"` is not valid TOML ("#),
        "{e}"
    );
    assert!(
        e.contains(": a bracket, brace or quote is left open); `faults.partitions` takes an array of tables, e.g. --set 'faults.partitions=[{kind = \"split\", start_s = 10, end_s = 20}]'"),
        "{e}"
    );
    // Balanced but not TOML: the parser's complaint alone.
    let e = set_err("contract.reward_weights=[1,,2]");
    assert!(
        e.starts_with("invalid override `contract.reward_weights=[1,,2]`: the value `[1,,2]` is not valid TOML (")
            && !e.contains("left open"),
        "{e}"
    );
    // An entry without its end.
    assert_eq!(
        set_err(r#"faults.partitions=[{kind="split", start_s=10}]"#),
        "configuration key `faults.partitions`: an entry lacks the field `end_s`; every entry \
         needs it, e.g. --set 'faults.partitions=[{kind = \"split\", start_s = 10, end_s = 20}]'"
    );
    // A misspelt field of an entry.
    let e = set_err(r#"faults.crashes=[{robot=0, start_s=1, ends=2}]"#);
    assert!(
        e.starts_with("configuration key `faults.crashes`: an entry has the unknown field `ends`; did you mean `end_s`? the fields are: robot, start_s, end_s"),
        "{e}"
    );
    // A negative robot inside an entry.
    let e = set_err("faults.crashes=[{robot=-1, start_s=1, end_s=2}]");
    assert!(
        e.starts_with("configuration key `faults.crashes`: an entry holds -1, where a whole number from 0 to 4294967295 is expected; e.g. --set 'faults.crashes=[{robot = 0, start_s = 10, end_s = 20}]'"),
        "{e}"
    );
    // A scalar where a list is expected names the list's own example.
    assert_eq!(
        set_err("contract.reward_weights=3"),
        "configuration key `contract.reward_weights`: value `3` has the wrong type; expected an \
         array, e.g. --set 'contract.reward_weights=[1, 1, -1]'"
    );
    // A huge number is written compactly, in a fault's window too.
    assert_eq!(
        set_err("run.duration_s=1e300"),
        "configuration key `run.duration_s`: value 1e300 is out of range; allowed: a number in \
         (0, 10000000]"
    );
    let e = set_err("faults.crashes=[{robot=0, start_s=-1e300, end_s=20}]");
    assert!(
        e.contains("`faults.crashes[0]`: value [-1e300, 20) is out of range"),
        "{e}"
    );
}

/// An unknown key names the nearest one: a typo of the field or of its table, or the same
/// field in another table; a file's too.
#[test]
fn an_unknown_key_suggests_the_nearest() {
    for (given, nearest) in [
        ("world.robotz=3", "world.robots"),
        ("wrld.robots=3", "world.robots"),
        ("robots=3", "world.robots"),
        ("contract.rulee=median", "contract.rule"),
    ] {
        let e = set_err(given);
        assert!(
            e.contains(&format!("did you mean `{nearest}`?")),
            "{given}: {e}"
        );
    }
    let e = set_err("world.zzzzzzzzzz=3");
    assert!(!e.contains("did you mean"), "{e}");
    let e = Config::from_toml_str("[world]\nrobotz = 3\n", "f.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("unknown configuration key `world.robotz (in f.toml)`; did you mean `world.robots`? world: "),
        "{e}"
    );
}

/// A file's value that the tree cannot take names its key and file (serde's own message names
/// neither).
#[test]
fn a_file_value_of_the_wrong_kind_names_its_key() {
    let e = Config::from_toml_str("[world]\nrobots = -3\n", "f.toml")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "configuration key `world.robots (in f.toml)`: value -3 is out of range; allowed: an \
         integer in [1, 10000]"
    );
    let e = Config::from_toml_str(
        "[faults]\npartitions = [{kind = \"split\", start_s = 10}]\n",
        "f.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with(
            "configuration key `faults.partitions (in f.toml)`: an entry lacks the field `end_s`"
        ),
        "{e}"
    );
}

/// Every list key has an example, and each example is accepted as it is shown.
#[test]
fn every_list_key_has_an_example_that_is_accepted() {
    let tree = super::overrides::full_tree_for_tests(&Preset::Smoke.config());
    let lists: Vec<String> = super::hints::dotted_keys(&tree)
        .into_iter()
        .filter(|k| {
            let mut v = &tree;
            for part in k.split('.') {
                v = &v[part];
            }
            v.is_array()
        })
        .collect();
    assert!(lists.len() >= 8, "{lists:?}");
    for key in lists {
        let example = super::hints::list_example(&key)
            .unwrap_or_else(|| panic!("{key} has no example in hints::list_example"));
        let mut c = Preset::Smoke.config();
        c.set(&format!("{key}={example}"))
            .unwrap_or_else(|e| panic!("{key}={example}: {e}"));
    }
}

#[test]
fn a_wrong_home_range_alpha_says_inf_is_allowed() {
    let e = Config::resolve(None, None, &["world.home_range.alpha=abc".into()])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("world.home_range.alpha") && e.contains("\"inf\""),
        "{e}"
    );
    let e = Config::resolve(None, None, &["world.arena_side_m=abc".into()])
        .unwrap_err()
        .to_string();
    assert!(e.ends_with("expected a number"), "{e}");
}

#[test]
fn home_ranges_are_left_out_of_the_recorded_text_at_their_default() {
    // At the default (alpha "inf") no record moves: the recorded text and its hash are the
    // preset's, whether the key is set or not; the full tree still lists the keys for --set.
    for preset in ["paper", "smoke"] {
        let plain = Config::resolve(Some(preset), None, &[]).unwrap();
        assert!(!plain.to_toml().contains("home_range"), "{preset}");
        let set = Config::resolve(
            Some(preset),
            None,
            &[
                "world.home_range.alpha=inf".into(),
                "world.home_range.regions=9".into(),
            ],
        )
        .unwrap();
        assert_eq!(set.to_toml(), plain.to_toml());
        assert_eq!(set.hash(), plain.hash());
        assert!(plain
            .to_toml_full()
            .contains("[world.home_range]\nalpha = inf"));
    }
    // On, the table is recorded and reads back.
    let on = Config::resolve(None, None, &["world.home_range.alpha=0.1".into()]).unwrap();
    let text = on.to_toml();
    assert!(
        text.contains("[world.home_range]\nregions = 9\nalpha = 0.1\ngoal_period_s = 60.0\n"),
        "{text}"
    );
    let back: Config = toml::from_str(&text).unwrap();
    assert_eq!(back, on);
    assert!(on.world.home_range.is_on() && !plain_paper().world.home_range.is_on());
}

fn plain_paper() -> Config {
    Preset::Paper.config()
}

#[test]
fn home_range_alpha_reads_inf_as_text_or_a_number_in_files_and_overrides() {
    let alpha = |text: &str| {
        Config::from_toml_str(text, "home.toml")
            .map(|c| c.world.home_range.alpha)
            .map_err(|e| e.to_string())
    };
    assert_eq!(
        alpha("[world.home_range]\nalpha = \"inf\"\n"),
        Ok(f64::INFINITY)
    );
    assert_eq!(
        alpha("[world.home_range]\nalpha = inf\n"),
        Ok(f64::INFINITY)
    );
    assert_eq!(alpha("[world.home_range]\nalpha = 0.3\n"), Ok(0.3));
    assert_eq!(alpha("[world.home_range]\nalpha = 2\n"), Ok(2.0));
    let err = alpha("[world.home_range]\nalpha = \"lots\"\n").unwrap_err();
    assert!(
        err.contains("world.home_range.alpha") && err.contains("home.toml"),
        "{err}"
    );
    for set in ["inf", "\"inf\"", "INF"] {
        let c = Config::resolve(None, None, &[format!("world.home_range.alpha={set}")]).unwrap();
        assert_eq!(c.world.home_range.alpha, f64::INFINITY, "{set}");
    }
    // "inf" as text on another number key is refused by that key's range.
    check_err(&["run.duration_s=\"inf\""], "run.duration_s");
}

#[test]
fn bad_home_ranges_are_refused_naming_the_key_the_value_and_the_fix() {
    let alpha = "world.home_range.alpha";
    let regions = "world.home_range.regions";
    for (set, expect) in [
        ("world.home_range.alpha=0", format!("`{alpha}`: value 0 ")),
        (
            "world.home_range.alpha=-0.5",
            format!("`{alpha}`: value -0.5 "),
        ),
        (
            "world.home_range.alpha=nan",
            format!("`{alpha}`: value NaN "),
        ),
        (
            "world.home_range.alpha=-inf",
            format!("`{alpha}`: value -inf "),
        ),
        (
            "world.home_range.regions=0",
            format!("`{regions}`: value 0 "),
        ),
        (
            "world.home_range.regions=8",
            format!("`{regions}`: value 8 "),
        ),
        ("world.home_range.regions=8", "regions=9".to_string()),
        (
            "world.home_range.goal_period_s=0",
            "world.home_range.goal_period_s".into(),
        ),
    ] {
        check_err(&[set], &expect);
    }
    // Too many regions for the arena: only with the knob on (the default grid never
    // refuses a configuration that does not use it).
    let many = ["world.home_range.regions=1600", "world.home_range.alpha=1"];
    check_err(&many, &format!("`{regions}`: value 1600 "));
    check_err(&many, "set world.home_range.regions=1225 or fewer");
    assert!(Config::resolve(None, None, &["world.home_range.regions=1600".into()]).is_ok());
    assert!(Config::resolve(
        None,
        None,
        &[
            "world.home_range.regions=1225".into(),
            "world.home_range.alpha=1".into()
        ]
    )
    .is_ok());
    // Another behaviour: refused, naming both keys.
    for behaviour in ["flocking", "foraging", "mixed"] {
        let set = [
            &format!("world.behaviour={behaviour}") as &str,
            "world.home_range.alpha=0.1",
        ];
        check_err(&set, &format!("`{alpha}`: value 0.1 "));
        check_err(
            &set,
            "set world.behaviour=avoidance or world.home_range.alpha=inf",
        );
    }
    assert!(Config::resolve(None, None, &["world.behaviour=flocking".into()]).is_ok());
}

#[test]
fn bad_authors_timing_is_refused_naming_the_key() {
    let jitter = "learn.authors_timing.byzantine_jitter_s";
    let service = "learn.authors_timing.service_time_s";
    check_err(
        &[&format!("{jitter}=-1")],
        &format!("`{jitter}`: value -1 "),
    );
    check_err(
        &[&format!("{jitter}=101")],
        &format!("`{jitter}`: value 101 "),
    );
    check_err(
        &[&format!("{service}=-0.5")],
        &format!("`{service}`: value -0.5 "),
    );
    check_err(
        &[&format!("{service}=nan")],
        &format!("`{service}`: value NaN "),
    );
    for aggregation in ["gossip", "central"] {
        let set = [
            "learn.timing=authors".to_string(),
            format!("learn.aggregation={aggregation}"),
        ];
        let set: Vec<&str> = set.iter().map(String::as_str).collect();
        check_err(&set, "`learn.timing`: value authors ");
        check_err(
            &set,
            "set learn.timing = independent or learn.aggregation = chain",
        );
    }
    check_err(
        &["learn.timing=authors", "learn.training_duration_s=2"],
        "`learn.training_duration_s`: value 2 ",
    );
    check_err(&["learn.timing=queued"], "learn.timing");
    // The same keys are fine under the default timing, and the preset resolves.
    assert!(Config::resolve(None, None, &["learn.training_duration_s=2".into()]).is_ok());
    let preset = Config::resolve(Some("authors-timing"), None, &[]).unwrap();
    assert_eq!(preset.learn.timing, crate::config::Timing::Authors);
    assert_eq!(
        preset.contract.options(),
        crate::config::ContractOptions::authors()
    );
}

#[test]
fn the_timing_is_left_out_of_the_recorded_text_at_its_default() {
    for preset in Preset::ALL.iter().filter(|p| **p != Preset::AuthorsTiming) {
        let text = preset.config().to_toml();
        assert!(!text.contains("timing"), "{}", preset.name());
    }
    let authors = Preset::AuthorsTiming.config().to_toml();
    assert!(authors.contains("timing = \"authors\""), "{authors}");
    assert!(
        !authors.contains("authors_timing"),
        "at its default: {authors}"
    );
}

#[test]
fn the_authors_gas_limits_need_the_evm_engine() {
    let resolve = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        Config::resolve(Some("smoke"), None, &sets)
    };
    let e = resolve(&["contract.gas_limit=estimate"])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("contract.gas_limit") && e.contains("contract.engine = evm"),
        "{e}"
    );
    let e = resolve(&["contract.gas_limit=bid"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("gas_limit"), "{e}");
    assert!(resolve(&["contract.gas_margin=0"]).is_ok());
    // Under the evm engine (in a build that has it) the option is accepted and recorded.
    if cfg!(feature = "evm") {
        let c = resolve(&[
            "contract.engine=evm",
            "contract.gas_limit=estimate",
            "contract.gas_margin=5000",
        ])
        .unwrap();
        let text = c.to_toml();
        assert!(text.contains("gas_limit = \"estimate\""), "{text}");
        assert!(text.contains("gas_margin = 5000"), "{text}");
        assert!(
            !text.contains("gas_estimate_state"),
            "at its default: {text}"
        );
        assert!(!text.contains("gas_recommit_s"), "at its default: {text}");
        let back: Config = toml::from_str(&text).unwrap();
        assert_eq!(back, c);
        let head = resolve(&[
            "contract.engine=evm",
            "contract.gas_limit=estimate",
            "contract.gas_estimate_state=head",
        ])
        .unwrap();
        assert!(head.to_toml().contains("gas_estimate_state = \"head\""));
        assert!(resolve(&[
            "contract.engine=evm",
            "contract.gas_limit=estimate",
            "contract.gas_recommit_s=0",
        ])
        .is_ok());
        let e = resolve(&[
            "contract.engine=evm",
            "contract.gas_limit=estimate",
            "contract.gas_estimate_state=head",
            "contract.gas_recommit_s=1",
        ])
        .unwrap_err()
        .to_string();
        assert!(e.contains("contract.gas_recommit_s"), "{e}");
    }
}

#[test]
fn the_estimate_state_and_recommit_need_the_estimated_gas_limits() {
    let resolve = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        Config::resolve(Some("smoke"), None, &sets)
    };
    let e = resolve(&["contract.gas_estimate_state=head"])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("contract.gas_estimate_state") && e.contains("contract.gas_limit = estimate"),
        "{e}"
    );
    let e = resolve(&["contract.gas_recommit_s=1"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("contract.gas_recommit_s"), "{e}");
    let e = resolve(&["contract.gas_estimate_state=latest"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("gas_estimate_state"), "{e}");
    // At their defaults nothing is recorded and nothing is refused.
    let c = resolve(&[
        "contract.gas_estimate_state=pending",
        "contract.gas_recommit_s=3",
    ])
    .unwrap();
    assert_eq!(c, resolve(&[]).unwrap());
}

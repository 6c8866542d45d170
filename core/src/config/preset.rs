//! The named configurations shipped with swarmfl: the paper's values, and each preset as the
//! paper's values with a few changes.

use std::fmt;

use super::behaviour::{
    Avoidance, Behaviour, FlockingConfig, ForagingConfig, ForagingRule, HomeRangeConfig,
    MixedAssign, MixedConfig, WindowRule,
};
use super::byzantine::{ByzantineKind, ByzantineVariant};
use super::contract::{
    ContractEngine, Defence, FedAvgRounding, MedianRule, OutlierRule, PayoutRounding, PoolRule,
    RankKey, RankOrder, RankTies, RoundProtocol, Rule, ThresholdRule,
};
use super::error::ConfigError;
use super::ledger::LedgerBehaviour;
use super::timing::{AuthorsTimingConfig, Timing};
use super::tree::{
    Aggregation, ByzantineConfig, Config, ContractConfig, DataConfig, Frame, LearnConfig,
    LedgerConfig, OutputConfig, RunConfig, WorldConfig, DEFAULT_ROUND_TIMEOUT_S,
};
use crate::faults::FaultsConfig;

/// The authors' contract as configuration overrides: every variant option of
/// docs/CONTRACT.md ("Differences from the authors' contract", rows 1 to 9) at the authors'
/// value, with the reward weights their script passes to `setInitWeights`. The `authors`
/// preset applies them to the paper's system, and the `-authors` experiments of `swarmfl
/// sweep` to each point. Their code's comment gives other weights, one override away:
/// `contract.reward_weights=[5,4,3,2,1,-1,-2]`.
pub const AUTHORS_CONTRACT: [&str; 9] = [
    "contract.median=mean",
    "contract.fedavg_rounding=truncate",
    "contract.int48_products=true",
    "contract.threshold=strict",
    "contract.rank_key=mae",
    "contract.rank_ties=quicksort",
    "contract.payout_rounding=ratio_1e9",
    "contract.pool=round",
    "contract.reward_weights=[1,1,1,1,1,-1,-1]",
];

/// The named configurations shipped with swarmfl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// The paper's values (the default), with the learning rate its code ran (0.01).
    Paper,
    /// The paper's text taken literally: as `Paper` but with its stated learning rate 0.001.
    PaperText,
    /// The reference implementation's values where they differ from the paper.
    Reference,
    /// 15 robots for 600 s: quick, for fixtures and CI.
    Smoke,
    /// The paper's system under the authors' contract: every variant option of
    /// docs/CONTRACT.md at the authors' value and their script's reward weights (issue #36).
    Authors,
    /// `authors` with the authors' timing (`learn.timing = "authors"`, issue #58): the
    /// Byzantine robots in step, the honest robots' trainings queued at one server.
    AuthorsTiming,
    /// Flow-FL's data-collection set-up (NESTLab TrajectoryCollection: Khepera IV robots and
    /// their avoidance in a 4 x 4 m arena, 2 m range, robots occlude): its obstacle-avoidance
    /// experiment. The other three experiments are the `flowfl-*` presets (issue #38;
    /// docs/SPEC.md section 1, "The `flowfl` presets").
    Flowfl,
    /// Flow-FL's flocking experiment: `flowfl` with every robot flocking to the light, no
    /// obstacles, 2.5 cm/s (`flocking_batch.argos`).
    FlowflFlocking,
    /// Flow-FL's foraging experiment: `flowfl` with every robot running Flow-FL's foraging
    /// (`world.foraging.rule = "flowfl"`: nest strip, moving items, probabilistic rest), no
    /// obstacles, 10 cm/s, 2 items per robot (`foraging_batch.argos`, `automate.sh`).
    FlowflForaging,
    /// Flow-FL's mixed experiment: `flowfl` with each robot's behaviour set by where it is,
    /// as Flow-FL's (`world.mixed.assign = "place"`, `world/place.rs`), no obstacles, its
    /// 5.9 m arena, 2 food sources per robot, the nest in the foraging region
    /// (`mixed_by_location_batch.argos`).
    FlowflMixed,
    /// Experiment 1: no security, no Byzantine robots; sweep `data.expiration_s`.
    E1Expiration,
    /// Experiment 1: no security, one faulty robot.
    E1Faulty,
    /// Experiment 2: security on, faulty robots; sweep `byzantine.count` 0..7.
    E2Faulty,
    /// Experiment 2: security on, malicious robots; sweep `byzantine.count` 0..7.
    E2Malicious,
    /// Experiment 3: security on, smart robots; sweep `byzantine.count` 0..7.
    E3Smart,
    /// Experiment 4: aggregation rules against attacks, 2000 s at learning rate 0.01; sweep
    /// `contract.rule` x `byzantine.kind` x `byzantine.count`.
    E4Robustness,
    /// Issue 16: smart robots against a defence of the reward rule (`contract.defence`).
    E5SmartDefence,
    /// Baselines: the chain (security on) against Flow-FL gossip and a central server; sweep
    /// `learn.aggregation` and the Byzantine robots.
    E0Baselines,
    /// Issue 32: the paper's system with the buffered protocol (`contract.protocol =
    /// "buffered"`); the `e6-scale` sweep grows it to 60, 240 and 1000 robots at the paper's
    /// density and compares it with the paper's rounds and the gossip baseline.
    E6Scale,
}

impl Preset {
    /// Every variant, in documentation order (the order `swarmfl presets` lists them).
    pub const ALL: [Preset; 19] = [
        Preset::Paper,
        Preset::PaperText,
        Preset::Reference,
        Preset::Authors,
        Preset::AuthorsTiming,
        Preset::Smoke,
        Preset::Flowfl,
        Preset::FlowflFlocking,
        Preset::FlowflForaging,
        Preset::FlowflMixed,
        Preset::E1Expiration,
        Preset::E1Faulty,
        Preset::E2Faulty,
        Preset::E2Malicious,
        Preset::E3Smart,
        Preset::E4Robustness,
        Preset::E5SmartDefence,
        Preset::E0Baselines,
        Preset::E6Scale,
    ];

    /// The preset's name as written on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Preset::Paper => "paper",
            Preset::PaperText => "paper-text",
            Preset::Reference => "reference",
            Preset::Authors => "authors",
            Preset::AuthorsTiming => "authors-timing",
            Preset::Smoke => "smoke",
            Preset::Flowfl => "flowfl",
            Preset::FlowflFlocking => "flowfl-flocking",
            Preset::FlowflForaging => "flowfl-foraging",
            Preset::FlowflMixed => "flowfl-mixed",
            Preset::E1Expiration => "e1-expiration",
            Preset::E1Faulty => "e1-faulty",
            Preset::E2Faulty => "e2-faulty",
            Preset::E2Malicious => "e2-malicious",
            Preset::E3Smart => "e3-smart",
            Preset::E4Robustness => "e4-robustness",
            Preset::E5SmartDefence => "e5-smart-defence",
            Preset::E0Baselines => "e0-baselines",
            Preset::E6Scale => "e6-scale",
        }
    }

    /// One line on what the preset is for.
    pub fn description(self) -> &'static str {
        match self {
            Preset::Paper => {
                "the paper's system: 15 robots, 5 x 5 m, 2.5 m range, 5000 s, security on, SGD 0.01"
            }
            Preset::PaperText => {
                "the paper's text: as `paper` but SGD 0.001 (its figures were made at 0.01)"
            }
            Preset::Reference => {
                "the reference implementation's values: 4 x 4 m, 2.0 m range, 4980 s, SGD 0.01"
            }
            Preset::Authors => {
                "the paper's system under the authors' contract (median, rounding, ranking, \
                 payouts, pool) and their script's reward weights [1,1,1,1,1,-1,-1]"
            }
            Preset::AuthorsTiming => {
                "`authors` with the authors' timing: Byzantine robots in step, honest \
                 trainings queued at one server (learn.timing = authors)"
            }
            Preset::Smoke => "15 robots for 600 s: quick, for fixtures and CI",
            Preset::Flowfl => {
                "Flow-FL's data collection, its avoidance experiment: Khepera IV and its pivot \
                 avoidance, 4 x 4 m, 5 + 5 obstacles, 2.0 m range, 5 cm/s"
            }
            Preset::FlowflFlocking => {
                "Flow-FL's flocking experiment: `flowfl`, all flocking to one light, no \
                 obstacles, 2.5 cm/s"
            }
            Preset::FlowflForaging => {
                "Flow-FL's foraging experiment: `flowfl`, Flow-FL's foraging (nest strip, \
                 moving items, probabilistic rest), no obstacles, 10 cm/s, 2 items per robot"
            }
            Preset::FlowflMixed => {
                "Flow-FL's mixed experiment: `flowfl`, behaviours by place (flocking beyond \
                 |x| = 2 m, avoidance where y > 0, foraging elsewhere), no obstacles, \
                 5.9 x 5.9 m, 2 food sources per robot"
            }
            Preset::E1Expiration => {
                "Exp. 1: security off, no Byzantine robots; sweep data.expiration_s 250..1250"
            }
            Preset::E1Faulty => "Exp. 1: security off, 1 faulty robot, expiration 750 s",
            Preset::E2Faulty => "Exp. 2: security on, faulty robots; sweep byzantine.count 0..7",
            Preset::E2Malicious => {
                "Exp. 2: security on, malicious robots; sweep byzantine.count 0..7"
            }
            Preset::E3Smart => "Exp. 3: security on, smart robots; sweep byzantine.count 0..7",
            Preset::E4Robustness => {
                "Exp. 4: rules x attacks x Byzantine count, 2000 s, learning rate 0.01"
            }
            Preset::E5SmartDefence => {
                "Exp. 5: smart robots against the agreement defence; sweep byzantine.count 0..7"
            }
            Preset::E0Baselines => {
                "Baselines: chain vs Flow-FL gossip vs central server, SGD 0.01; sweep \
                 learn.aggregation x {0, 1 faulty, 3 malicious}"
            }
            Preset::E6Scale => {
                "Scale: the paper's system with the buffered protocol (K = 7); sweep robots \
                 15..1000 at the paper's density x rounds / buffered / gossip"
            }
        }
    }

    /// Looks a preset up by name.
    pub fn from_name(name: &str) -> Result<Preset, ConfigError> {
        Preset::ALL
            .iter()
            .copied()
            .find(|p| p.name() == name)
            .ok_or_else(|| ConfigError::UnknownPreset {
                name: name.to_string(),
                allowed: Preset::ALL
                    .iter()
                    .map(|p| p.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// The preset's full configuration.
    pub fn config(self) -> Config {
        let mut c = Config::paper();
        c.preset = self.name().to_string();
        match self {
            Preset::Paper => {}
            Preset::PaperText => {
                // The rate the paper's text gives (taken from Flow-FL); its code never set one,
                // so Keras' default 0.01 made the figures (docs/SPEC.md, "Learning rate").
                c.learn.learning_rate = 0.001;
            }
            Preset::Reference => {
                c.run.duration_s = 4980.0;
                c.world.arena_side_m = 4.0;
                c.world.obstacle_spread_half_m = 1.5;
                c.world.rab_range_m = 2.0;
            }
            Preset::Authors => {
                for assignment in AUTHORS_CONTRACT {
                    c.set(assignment)
                        .expect("the authors' contract options are valid keys and values");
                }
            }
            Preset::AuthorsTiming => {
                c = Preset::Authors.config();
                c.preset = self.name().to_string();
                c.learn.timing = Timing::Authors;
            }
            Preset::Smoke => {
                c.run.duration_s = 600.0;
            }
            Preset::Flowfl => flowfl(&mut c),
            Preset::FlowflFlocking | Preset::FlowflForaging | Preset::FlowflMixed => {
                c = Preset::Flowfl.config();
                c.preset = self.name().to_string();
                flowfl_experiment(&mut c, self);
            }
            Preset::E1Expiration => {
                c.contract.security = false;
            }
            Preset::E1Faulty => {
                c.contract.security = false;
                c.byzantine.kind = ByzantineKind::Faulty;
                c.byzantine.count = 1;
            }
            Preset::E2Faulty => {
                c.byzantine.kind = ByzantineKind::Faulty;
                c.byzantine.count = 1;
            }
            Preset::E2Malicious => {
                c.byzantine.kind = ByzantineKind::Malicious;
                c.byzantine.count = 1;
            }
            Preset::E3Smart => {
                c.byzantine.kind = ByzantineKind::Smart;
                c.byzantine.count = 1;
            }
            Preset::E4Robustness => {
                // Short runs by default (the sweep has 225 points); --set run.duration_s=5000
                // for the paper's length.
                c.run.duration_s = 2000.0;
            }
            Preset::E5SmartDefence => {
                // e3-smart with the defence that measured best (RESEARCH.md, e5-smart-defence).
                c.byzantine.kind = ByzantineKind::Smart;
                c.byzantine.count = 1;
                c.contract.defence = Defence::Agreement;
            }
            Preset::E0Baselines => {
                // The paper's system (security on, learning rate 0.01, docs/SPEC.md section
                // 2) at its full 5000 s; the sweep varies learn.aggregation and the Byzantine
                // robots.
            }
            Preset::E6Scale => {
                // The paper's system, buffered; the sweep sets the swarm's size (and the
                // arena and obstacles that keep the paper's density) and the protocol.
                c.contract.protocol = RoundProtocol::Buffered;
            }
        }
        c
    }
}

/// Flow-FL's data collection (its avoidance experiment) over the paper's values: its arena,
/// Khepera IV robots and their avoidance, and the flocking and foraging parameters its other
/// experiments start from.
fn flowfl(c: &mut Config) {
    // NESTLab/TrajectoryCollection, argos-scripts/experiments/*_batch.argos and
    // controllers/: the values and their sources are in docs/SPEC.md section 1.
    // Walls 0.1 m thick centered at +-2 m: 3.9 m between their faces.
    c.world.arena_side_m = 3.9;
    c.world.obstacle_spread_half_m = 0.0;
    c.world.rab_range_m = 2.0;
    c.world.robot_radius_m = 0.0704;
    c.world.wheel_base_m = 0.1054;
    c.world.cruise_speed_mps = 0.05;
    c.world.random_turn_rate_per_s = 0.0;
    c.world.rab_robot_occlusion = true;
    c.data.window_rule = WindowRule::Confirmed;
    // Flow-FL's `khepera_obstacleavoidance` on ARGoS's Khepera IV ring: a pivot on
    // one wheel while a front reading is above 0 (`world/khepera.rs`), and
    // ARGoS's dynamics2d contacts (robots slide along what they push).
    c.world.avoidance = Avoidance::Khepera;
    c.world.proximity_range_m = 0.12;
    c.world.proximity_threshold = 0.0;
    c.world.slide_on_contact = true;
    // Flow-FL's flocking (`flocking_batch.argos`, `khepera_flocking.cpp`): one
    // fixed light at (-2, -1.5) on the west wall, no alignment term, and the
    // Lennard-Jones interaction capped at 0.2 against the light's 2.5 (0.08).
    c.world.flocking.goal_x_m = -1.95;
    c.world.flocking.goal_y_m = -1.5;
    c.world.flocking.goal_swap_s = 0.0;
    c.world.flocking.alignment_weight = 0.0;
    c.world.flocking.cohesion_weight = 0.08;
    // Flow-FL's foraging (`foraging_batch.argos`): items of radius 0.1 m, and a
    // rest of at least 2 ticks left with probability 0.1 a tick (about 1 s).
    c.world.foraging.food_radius_m = 0.1;
    c.world.foraging.rest_s = 1.0;
}

/// The arena of Flow-FL's flocking, foraging and mixed experiments over `flowfl`'s (its
/// avoidance experiment): `flocking_batch.argos`, `foraging_batch.argos`,
/// `mixed_by_location_batch.argos` and `bash-scripts/automate.sh` of NESTLab/TrajectoryCollection;
/// docs/SPEC.md section 1 has each value beside Flow-FL's.
fn flowfl_experiment(c: &mut Config, experiment: Preset) {
    // No obstacles in any of the three arenas.
    c.world.cylinders = 0;
    c.world.boxes = 0;
    match experiment {
        Preset::FlowflFlocking => {
            c.world.behaviour = Behaviour::Flocking;
            // The light vector is 0.25 x max_speed: 2.5 cm/s (`khepera_flocking.cpp`).
            c.world.cruise_speed_mps = 0.025;
        }
        Preset::FlowflForaging => {
            c.world.behaviour = Behaviour::Foraging;
            c.world.foraging.rule = ForagingRule::Flowfl;
            // `max_speed="10"` cm/s; `FOOD_ITEMS = NBROBOTS x FOOD_FACTOR`, FOOD_FACTOR = 2.
            c.world.cruise_speed_mps = 0.1;
            c.world.foraging.food_per_robot = 2;
        }
        Preset::FlowflMixed => {
            c.world.behaviour = Behaviour::Mixed;
            // By place (`khepera_mixed.cpp`, `ControlStep`).
            c.world.mixed.assign = MixedAssign::Place;
            // Walls at +-3 m, 0.1 m thick: 5.9 m between their faces.
            c.world.arena_side_m = 5.9;
            c.world.foraging.food_per_robot = 2;
            // Flow-FL's nest is the strip x < -1 m (`mixed_loop_functions.cpp`); its part in
            // the foraging region (-2 < x < -1, y < 0) holds our nest disk of 1 m across,
            // which at its default (-1.4, 0) would lie half in the avoidance region.
            c.world.foraging.nest_x_m = -1.5;
            c.world.foraging.nest_y_m = -1.5;
        }
        _ => unreachable!("flowfl_experiment is called for the three flowfl-* experiments"),
    }
}

impl Preset {
    /// The preset of Flow-FL's experiment for `behaviour`: `flowfl` (avoidance),
    /// `flowfl-flocking`, `flowfl-foraging` or `flowfl-mixed`; `swarmfl data-volume
    /// --experiments` measures each behaviour under it.
    pub fn flowfl_experiment(behaviour: Behaviour) -> Preset {
        match behaviour {
            Behaviour::Avoidance => Preset::Flowfl,
            Behaviour::Flocking => Preset::FlowflFlocking,
            Behaviour::Foraging => Preset::FlowflForaging,
            Behaviour::Mixed => Preset::FlowflMixed,
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Default for Config {
    fn default() -> Self {
        Preset::Paper.config()
    }
}

impl Config {
    /// The paper's values, which every preset starts from.
    fn paper() -> Config {
        Config {
            preset: "paper".to_string(),
            run: RunConfig {
                duration_s: 5000.0,
                tick_s: 0.1,
            },
            world: paper_world(),
            data: paper_data(),
            learn: paper_learn(),
            ledger: LedgerConfig {
                block_period_s: 10.0,
                wiggle_unit_s: 0.5,
                bandwidth_bytes_per_s: 0,
                packet_loss: 0.0,
            },
            contract: paper_contract(),
            byzantine: paper_byzantine(),
            faults: FaultsConfig::default(),
            output: OutputConfig {
                snapshot_every_blocks: 50,
            },
        }
    }
}

/// The paper's arena, robots, sensors and behaviour (the authors' ARGoS setup).
fn paper_world() -> WorldConfig {
    WorldConfig {
        robots: 15,
        arena_side_m: 5.0,
        cylinders: 5,
        cylinder_radius_m: 0.15,
        boxes: 5,
        box_side_m: 0.3,
        obstacle_spread_half_m: 0.0,
        robot_radius_m: 0.035,
        wheel_base_m: 0.053,
        cruise_speed_mps: 0.025,
        proximity_sensors: 8,
        proximity_range_m: 0.1,
        proximity_threshold: 0.2,
        // The authors' code makes no random turns (`RandomWalk.step` in
        // `controllers/movement.py` has `self.random()` commented out): its robots turn
        // only to avoid. docs/SPEC.md section 1, "Data volume".
        random_turn_rate_per_s: 0.0,
        random_turn_max_s: 3.0,
        rab_range_m: 2.5,
        rab_noise_std_m: 0.01,
        rab_occlusion: true,
        rab_packet_drop: 0.0,
        peer_refresh_s: 0.5,
        // ARGoS' range-and-bearing medium, which the authors' code ran: other robots'
        // bodies block the line of sight too.
        rab_robot_occlusion: true,
        behaviour: Behaviour::Avoidance,
        mixed: MixedConfig::default(),
        flocking: FlockingConfig::default(),
        foraging: ForagingConfig::default(),
        // The authors' avoidance on ARGoS's e-puck (`RandomWalk.avoid` in
        // `controllers/movement.py`, the e-puck proximity ring), and ARGoS's contacts:
        // a robot pushing against something slides along it. Without both, robots
        // that make no random turns deadlock. docs/SPEC.md section 1, "Data volume".
        avoidance: Avoidance::Epuck,
        slide_on_contact: true,
        home_range: HomeRangeConfig::default(),
    }
}

/// The paper's trajectory windows and held-out set.
fn paper_data() -> DataConfig {
    DataConfig {
        trajectory_ticks: 100,
        input_waypoints: 32,
        target_waypoints: 48,
        expiration_s: 750.0,
        heldout_samples: 200,
        heldout_windows: super::tree::default_heldout_windows(),
        // The authors' `controllers/main.py` (ported from Flow-FL): a window is saved
        // at the next reading after its 100th, and the reading after a gap is dropped.
        window_rule: WindowRule::Confirmed,
    }
}

/// The paper's model and training.
fn paper_learn() -> LearnConfig {
    LearnConfig {
        lstm_units: 16,
        dropout: 0.2,
        // Keras' default for `optimizer='SGD'`, what the authors' code ran (the text says
        // 0.001; the `paper-text` preset keeps that value).
        learning_rate: 0.01,
        batch_size: 20,
        epochs: 20,
        train_fraction: 0.8,
        training_period_s: 100.0,
        training_duration_s: 0.0,
        min_train_samples: 1,
        timing: Timing::Independent,
        authors_timing: AuthorsTimingConfig::default(),
        aggregation: Aggregation::Chain,
        gossip_outlier_filter: false,
        frame: Frame::World,
        withheld: Vec::new(),
    }
}

/// The paper's contract: security on, its tokens, quorum, threshold and ranking, every variant option at swarmfl's default.
fn paper_contract() -> ContractConfig {
    ContractConfig {
        security: true,
        initial_tokens: 21,
        stake_tokens: 5,
        token_units: 1_000_000_000,
        weight_scale: 1_000_000_000,
        quorum_fraction: 0.5,
        outlier_threshold: 0.05,
        penalised_ranks: 2,
        rule: Rule::Paper,
        rule_plugin: String::new(),
        assumed_f: 1,
        round_timeout_s: DEFAULT_ROUND_TIMEOUT_S,
        max_claimed_samples: 0,
        reward_weights: Vec::new(),
        engine: ContractEngine::Native,
        median: MedianRule::Lower,
        fedavg_rounding: FedAvgRounding::Nearest,
        int48_products: false,
        threshold: ThresholdRule::Inclusive,
        rank_key: RankKey::Distance,
        rank_ties: RankTies::Stable,
        rank_order: RankOrder::Median,
        payout_rounding: PayoutRounding::Exact,
        pool: PoolRule::Carry,
        defence: Defence::None,
        block_gas_limit: super::tree::AUTHORS_BLOCK_GAS_LIMIT,
        gas_limit: Default::default(),
        gas_margin: super::tree::WEB3_GAS_MARGIN,
        gas_estimate_state: Default::default(),
        gas_recommit_s: super::tree::GETH_RECOMMIT_S,
        defence_refund_percent: 50,
        preaggregators: Vec::new(),
        threshold_gate: false,
        bucket_size: 2,
        clip_radius: 1.0,
        protocol: RoundProtocol::Rounds,
        buffer_size: super::tree::default_buffer_size(),
        max_staleness: super::tree::default_max_staleness(),
        staleness_exponent: super::tree::default_staleness_exponent(),
        server_step: super::tree::default_server_step(),
        outlier_rule: OutlierRule::Absolute,
        outlier_factor: super::tree::default_outlier_factor(),
        outlier_window: super::tree::default_outlier_window(),
        outlier_cap: super::tree::default_outlier_cap(),
    }
}

/// No Byzantine robot; each attack's parameters at their defaults.
fn paper_byzantine() -> ByzantineConfig {
    ByzantineConfig {
        kind: ByzantineKind::None,
        count: 0,
        variant: ByzantineVariant::Paper,
        claimed_samples: 200,
        faulty_range: 0.5,
        wait_for_honest: 2,
        scale: 1.0,
        sigma: 0.1,
        alie_z: 1.0,
        threshold_fraction: 0.99,
        inflated_samples: u32::MAX,
        ledger: LedgerBehaviour::Honest,
        switch_token_share: 0.5,
        search_evals: 20,
        plugin: String::new(),
        as_honest: Vec::new(),
    }
}

//! The paper's experiments (docs/SPEC.md section 7): each one a preset, a grid of
//! configuration points and a number of runs, and the fixed task list they expand into.
//!
//! `swarmfl sweep` runs the tasks and `swarmfl report` reads their results back; both take the
//! grids from here, so a point's name, overrides and tags have one definition.
//!
//! The task list of an experiment with points `p = 0..P` (in the order [`experiment`] lists
//! them) and `R` runs is point-major: task `i = p * R + (seed - 1)`, seeds `1..=R`.

use swarmfl_core::config::{Behaviour, ByzantineKind, Defence, Preset, Rule};

mod heterogeneity;
mod scale;
pub use heterogeneity::{
    hetero_rule_name, Front, HETERO_ALPHAS, HETERO_ATTACKS, HETERO_RULES, HETERO_RUNS,
};
pub use scale::{
    e6_capped_training_period_s, paper_density, E6_FAULTY, E6_PROTOCOLS, E6_TRAINING_PERIOD_S,
};
use scale::{e6_gossip_points, e6_points};

/// The experiments, in the order `swarmfl sweep --help` lists them: the one list, each named
/// once, with everything `swarmfl sweep` and `swarmfl report` know of it.
pub const ALL: [Entry; 22] = [
    Entry {
        id: Id::Preset,
        preset: Preset::E0Baselines,
        axis: "Byzantine robots",
        points: baselines_grid,
        runs: 5,
        drawn_by: DrawnBy::Baselines,
    },
    Entry {
        id: Id::Preset,
        preset: Preset::E1Expiration,
        axis: "data expiration (s)",
        points: expiration_grid,
        runs: 5,
        drawn_by: DrawnBy::Standard(Standard {
            loss: "per data expiration time, no Byzantine robots, no security",
            legend: Legend::ExpirationS,
            beside: None,
        }),
    },
    Entry {
        id: Id::Preset,
        preset: Preset::E1Faulty,
        axis: "faulty robots",
        points: faulty_point,
        runs: 10,
        drawn_by: DrawnBy::Standard(Standard {
            loss: "with one faulty robot, no security",
            legend: Legend::OneFaulty,
            // The same system without the faulty robot.
            beside: Some(Beside {
                experiment: Preset::E1Expiration.name(),
                point: "expiration-750",
                label: "no Byzantine (e1-expiration 750 s)",
            }),
        }),
    },
    Entry {
        id: Id::Preset,
        preset: Preset::E2Faulty,
        axis: "faulty robots",
        points: byzantine_grid,
        runs: 20,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of faulty robots, security on",
        )),
    },
    Entry {
        id: Id::Preset,
        preset: Preset::E2Malicious,
        axis: "malicious robots",
        points: byzantine_grid,
        runs: 20,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of malicious robots, security on",
        )),
    },
    Entry {
        id: Id::Preset,
        preset: Preset::E3Smart,
        axis: "smart robots",
        points: byzantine_grid,
        runs: 18,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of smart robots, security on",
        )),
    },
    Entry {
        id: Id::Preset,
        preset: Preset::E4Robustness,
        axis: "Byzantine robots",
        points: e4_points,
        runs: 3,
        drawn_by: DrawnBy::Robustness,
    },
    Entry {
        id: Id::Own("e4-benchmark"),
        preset: Preset::E4Robustness,
        axis: "Byzantine robots",
        points: bench_points,
        runs: 3,
        drawn_by: DrawnBy::Benchmark,
    },
    Entry {
        id: Id::Own("e4-gate"),
        preset: Preset::E4Robustness,
        axis: "Byzantine robots",
        points: gate_points,
        runs: 3,
        drawn_by: DrawnBy::Standard(Standard::OTHER),
    },
    Entry {
        id: Id::Own("e4-heterogeneity"),
        preset: Preset::E4Robustness,
        axis: "Byzantine robots",
        points: heterogeneity::hetero_points,
        runs: HETERO_RUNS,
        drawn_by: DrawnBy::Heterogeneity,
    },
    Entry {
        id: Id::Preset,
        preset: Preset::E5SmartDefence,
        axis: "Byzantine robots",
        points: e5_points,
        runs: 3,
        drawn_by: DrawnBy::Defence,
    },
    Entry {
        id: Id::Own("e2-malicious-authors"),
        preset: Preset::Authors,
        axis: "malicious robots",
        points: || authors_grid(ByzantineKind::Malicious),
        runs: 20,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of malicious robots, security on, the authors' contract",
        )),
    },
    Entry {
        id: Id::Own("e3-smart-authors"),
        preset: Preset::Authors,
        axis: "smart robots",
        points: || authors_grid(ByzantineKind::Smart),
        runs: 18,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of smart robots, security on, the authors' contract",
        )),
    },
    // Issue 58: the same two under the authors' timing (the `authors-timing` preset: the
    // authors' contract, the Byzantine robots in step, the honest trainings queued at one
    // server), at the paper's run counts; `-code` adds the smart robot as the authors' code
    // runs it (`byzantine.variant = "authors"`).
    Entry {
        id: Id::Own("e2-malicious-authors-timing"),
        preset: Preset::AuthorsTiming,
        axis: "malicious robots",
        points: || authors_grid(ByzantineKind::Malicious),
        runs: 20,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of malicious robots, security on, the authors' contract and timing",
        )),
    },
    Entry {
        id: Id::Own("e3-smart-authors-timing"),
        preset: Preset::AuthorsTiming,
        axis: "smart robots",
        points: || authors_grid(ByzantineKind::Smart),
        runs: 18,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of smart robots, security on, the authors' contract and timing",
        )),
    },
    Entry {
        id: Id::Own("e3-smart-authors-code"),
        preset: Preset::AuthorsTiming,
        axis: "smart robots",
        points: authors_code_grid,
        runs: 18,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of smart robots, the authors' contract, timing and smart robot",
        )),
    },
    // Issue 58: the two under the authors' timing with the authors' gas too (the EVM engine,
    // `contract.gas_limit = "estimate"`: a transaction's limit is its node's estimate plus
    // 100,000, so a submission that lands as the round's closing one can run out of gas).
    // A sweep needs a build with `--features evm`; without it every task is refused.
    Entry {
        id: Id::Own("e2-malicious-authors-gas"),
        preset: Preset::AuthorsTiming,
        axis: "malicious robots",
        points: || authors_gas_grid(ByzantineKind::Malicious),
        runs: 20,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of malicious robots, the authors' contract, timing and gas",
        )),
    },
    Entry {
        id: Id::Own("e3-smart-authors-gas"),
        preset: Preset::AuthorsTiming,
        axis: "smart robots",
        points: || authors_gas_grid(ByzantineKind::Smart),
        runs: 18,
        drawn_by: DrawnBy::Standard(Standard::byzantine(
            "per number of smart robots, the authors' contract, timing and gas",
        )),
    },
    // Issue 32. Two experiments so that each has one number of runs: 3 seeds up to 240
    // robots, 2 at 1000 (whose runs take minutes each).
    Entry {
        id: Id::Preset,
        preset: Preset::E6Scale,
        axis: "robots",
        points: || e6_points(&[15, 60, 240], true),
        runs: 3,
        drawn_by: DrawnBy::Scale,
    },
    // Issue 55: the measure of position heterogeneity against the home ranges' alpha, in
    // world-only runs (no robot trains).
    Entry {
        id: Id::Own("e4-heterogeneity-measure"),
        preset: Preset::Paper,
        axis: "home-range alpha",
        points: heterogeneity_measure_points,
        runs: 3,
        drawn_by: DrawnBy::PositionMeasure,
    },
    Entry {
        id: Id::Own("e6-scale-1000"),
        preset: Preset::E6Scale,
        axis: "robots",
        points: || e6_points(&[1000], false),
        runs: 2,
        drawn_by: DrawnBy::Scale,
    },
    // Gossip at 1000 robots on its own (issue 56): its cost is unknown, so it can be measured
    // with one short run (`--set run.duration_s=1000`) before the whole is run.
    Entry {
        id: Id::Own("e6-scale-1000-gossip"),
        preset: Preset::E6Scale,
        axis: "robots",
        points: || e6_gossip_points(&[1000]),
        runs: 2,
        drawn_by: DrawnBy::Scale,
    },
];

/// The names of the experiments of [`ALL`], in its order.
pub const EXPERIMENTS: [&str; ALL.len()] = {
    let mut names = [""; ALL.len()];
    let mut i = 0;
    while i < ALL.len() {
        names[i] = ALL[i].name();
        i += 1;
    }
    names
};

/// A built-in experiment: its name, the preset and grid its tasks run, and the study report
/// that draws its results.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// The experiment's id (see [`Entry::name`]).
    pub id: Id,
    /// The preset every point starts from.
    pub preset: Preset,
    /// What the grid varies, for axis labels (`data expiration (s)`, `Byzantine robots`).
    pub axis: &'static str,
    /// The grid, in task order.
    pub points: fn() -> Vec<Point>,
    /// The paper's runs per point.
    pub runs: u32,
    /// The study report that draws its figures and tables (`report/`).
    pub drawn_by: DrawnBy,
}

/// Where an experiment's name comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Id {
    /// Its preset's name: `e2-faulty` runs the preset `e2-faulty`.
    Preset,
    /// A name of its own, for a further experiment on a preset (`e4-gate` on `e4-robustness`).
    Own(&'static str),
}

/// The study report that draws an experiment's figures and tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DrawnBy {
    /// The standard figures (`report/figures.rs`): loss over time per point, tokens gained
    /// versus the number of Byzantine robots, chain size over time.
    Standard(Standard),
    /// The baselines' figures (`report/figures.rs`): held-out loss per Byzantine condition,
    /// bytes per robot per aggregation.
    Baselines,
    /// Heatmaps of rule x attack per Byzantine count and the worst-case table
    /// (`report/robustness.rs`).
    Robustness,
    /// The robustness benchmark's heatmaps on a heterogeneity axis (`report/benchmark.rs`).
    Benchmark,
    /// The heterogeneity benchmark's heatmaps of rule x home-range alpha, destroyed runs and
    /// per-seed spread (`report/heterogeneity/`).
    Heterogeneity,
    /// Figures per defence and the table of Byzantine control (`report/defence.rs`).
    Defence,
    /// The scale study's figures and tables, shared by its experiments (`report/scale/`).
    Scale,
    /// The position-heterogeneity measure per home-range alpha and swarm size
    /// (`report/position.rs`).
    PositionMeasure,
}

/// How the standard figures show an experiment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Standard {
    /// What the loss figure's lines are, in its caption (`per number of faulty robots,
    /// security on`).
    pub loss: &'static str,
    /// A point's legend label.
    pub legend: Legend,
    /// A point of another experiment drawn beside the loss curves, for comparison.
    pub beside: Option<Beside>,
}

impl Standard {
    /// The standard figures of an experiment without a caption of its own (`per
    /// configuration`): a `--grid` sweep's, `e4-gate`'s.
    pub const OTHER: Standard = Standard::byzantine("per configuration");

    /// Figures of a grid of Byzantine counts, the loss caption saying `loss`.
    const fn byzantine(loss: &'static str) -> Standard {
        Standard {
            loss,
            legend: Legend::Byzantine,
            beside: None,
        }
    }
}

/// What a point's legend label says of its x.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Legend {
    /// The data expiration in s (`expiration 750 s`). No figure of tokens versus x: x counts
    /// no robots.
    ExpirationS,
    /// The experiment's one point: one faulty robot (`1 faulty robot`).
    OneFaulty,
    /// Byzantine robots (`3 Byzantine`).
    Byzantine,
}

/// A point of another experiment drawn beside an experiment's loss curves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Beside {
    /// The other experiment.
    pub experiment: &'static str,
    /// Its point.
    pub point: &'static str,
    /// The curve's legend label.
    pub label: &'static str,
}

impl Entry {
    /// The experiment's id: the results' directory name, what `swarmfl sweep` takes.
    pub const fn name(&self) -> &'static str {
        match self.id {
            Id::Preset => self.preset.name(),
            Id::Own(name) => name,
        }
    }

    /// The experiment: its grid built.
    pub fn experiment(&self) -> Experiment {
        Experiment {
            name: self.name().to_string(),
            preset: self.preset.name().to_string(),
            axis: self.axis.to_string(),
            points: (self.points)(),
            runs: self.runs,
        }
    }
}

/// The built-in experiment named `name`, if there is one.
pub fn entry(name: &str) -> Option<&'static Entry> {
    ALL.iter().find(|e| e.name() == name)
}

/// Byzantine counts of `e4-robustness`: none (each rule's clean reference), a minority (3 of
/// 15: about 1.4 per 7-model round, near the rules' assumed f) and the largest minority (7 of
/// 15: about 3.3 per round, beyond every rule's f at quorum 7). Three counts keep the grid at
/// 9 + 9 x 12 x 2 = 225 points per seed (about 1.6 h of one core per seed at 2000 s);
/// 0, 1, 3, 5, 7 would be 441.
pub const E4_COUNTS: [u32; 3] = [0, 3, 7];

/// The attacks of e4-robustness, in its grid's order: named, not a slice of
/// [`ByzantineKind::ALL`], so that a new attack in the registry cannot reshape the published
/// grid (smart-then-collude is e5-smart-defence's attack, and the kinds after it in the
/// registry are issue 33's).
pub const E4_ATTACKS: [ByzantineKind; 12] = [
    ByzantineKind::Faulty,
    ByzantineKind::Malicious,
    ByzantineKind::Smart,
    ByzantineKind::SignFlip,
    ByzantineKind::Gaussian,
    ByzantineKind::Alie,
    ByzantineKind::Ipm,
    ByzantineKind::MinMax,
    ByzantineKind::Mimic,
    ByzantineKind::InflateSamples,
    ByzantineKind::PoisonData,
    ByzantineKind::Collude,
];

/// The rules of the published `e4-robustness` grid (the first nine of [`Rule::ALL`]): the rules
/// issue #33 added (mda, meamed, monna, signguard, dnc) are not in it, so the committed study
/// keeps its 225 points.
pub const E4_RULES: [Rule; 9] = [
    Rule::Fedavg,
    Rule::Paper,
    Rule::Krum,
    Rule::MultiKrum,
    Rule::Median,
    Rule::TrimmedMean,
    Rule::Geomed,
    Rule::CenteredClipping,
    Rule::Bulyan,
];

/// The swarms of `e4-benchmark`, its heterogeneity axis (issue #33 on issue #38's behaviours):
/// a flock (the least heterogeneous data measured, `world.data_heterogeneity` about 0.01), a
/// mixed swarm (a third of each behaviour) and the paper's avoidance walk (the most). The
/// report orders them by the heterogeneity its runs measured.
pub const BENCH_BEHAVIOURS: [Behaviour; 3] =
    [Behaviour::Flocking, Behaviour::Mixed, Behaviour::Avoidance];

/// The rules of `e4-benchmark`, each alone and, where marked, behind the NNM pre-aggregator
/// (ByzFL's recommended composition; on the four rules of four kinds: coordinate-wise median
/// and trimmed mean, Krum's selection, centered clipping): the paper's rule and FedAvg as
/// references, and every robust rule but multi-krum (krum's selection averaged; close to krum
/// at quorum 7) and bulyan (at quorum 7 it tolerates one Byzantine model only).
pub const BENCH_RULES: [(Rule, bool); 16] = [
    (Rule::Paper, false),
    (Rule::Fedavg, false),
    (Rule::Median, false),
    (Rule::TrimmedMean, false),
    (Rule::Krum, false),
    (Rule::Geomed, false),
    (Rule::CenteredClipping, false),
    (Rule::Mda, false),
    (Rule::Meamed, false),
    (Rule::Monna, false),
    (Rule::Signguard, false),
    (Rule::Dnc, false),
    (Rule::Median, true),
    (Rule::TrimmedMean, true),
    (Rule::Krum, true),
    (Rule::CenteredClipping, true),
];

/// The attacks of `e4-benchmark`: the strongest of a 5000 s pilot (all 17 attacks against
/// median and krum, 5 of 15 Byzantine, avoidance, seed 1; RESEARCH.md, "The robustness
/// benchmark"): the two adaptive attacks that line-search against the rule the contract runs
/// and the extreme values, which blew both rules' models up (held-out 1e8 to 1e11), and
/// sign flipping, the strongest of those that did not (1.02 against median), for the rules that
/// stop the first three.
pub const BENCH_ATTACKS: [ByzantineKind; 4] = [
    ByzantineKind::OptimalAlie,
    ByzantineKind::OptimalIpm,
    ByzantineKind::ExtremeValue,
    ByzantineKind::SignFlip,
];

/// Byzantine counts of `e4-benchmark`: none (each cell's clean reference), 3 of 15 (about 1.4
/// per 7-model round, within the rules' assumed f = 2) and 5 (about 2.3 per round, at and
/// beyond it).
pub const BENCH_COUNTS: [u32; 3] = [0, 3, 5];

/// The rules `e4-gate` runs behind the paper's threshold (`contract.threshold_gate`): the
/// coordinate-wise median and Krum, the two selection rules with the fewest destroyed runs of
/// `e4-benchmark` at 5 Byzantine robots.
pub const GATE_RULES: [Rule; 2] = [Rule::Median, Rule::Krum];

/// The name of a rule of [`BENCH_RULES`] in point names and figures: `median`, or
/// `nnm+median` behind NNM.
pub fn bench_rule_name(rule: Rule, nnm: bool) -> String {
    if nnm {
        format!("nnm+{}", rule.name())
    } else {
        rule.name().to_string()
    }
}

/// The assumed Byzantine count `e4-robustness` gives each rule: 2 (a rule built for the
/// expected 1.4 and a margin), except bulyan, whose maximum at quorum 7 is 1.
pub fn e4_assumed_f(rule: Rule) -> u32 {
    if rule == Rule::Bulyan {
        1
    } else {
        2
    }
}

/// One configuration point of an experiment's grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// The point's name: a directory name (e.g. `expiration-750`, `byzantine-3`).
    pub name: String,
    /// The grid value (expiration in s, or number of Byzantine robots), for plotting.
    pub x: f64,
    /// The configuration overrides that make this point from the experiment's preset.
    pub overrides: Vec<String>,
    /// The point's coordinates on further axes, by axis name (e4: `rule`, `attack`).
    pub tags: Vec<(&'static str, String)>,
}

impl Point {
    /// The value of the point's tag `key`, if it has one.
    pub fn tag(&self, key: &str) -> Option<String> {
        self.tags
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| v.clone())
    }
}

/// One experiment: a preset, its grid of points and the paper's number of runs per point.
#[derive(Clone, Debug, PartialEq)]
pub struct Experiment {
    /// The experiment's id: the results' directory name (a built-in experiment's is also its
    /// preset's name; a grid's is `grid-<preset>`).
    pub name: String,
    /// The preset every point starts from.
    pub preset: String,
    /// What the grid varies, for axis labels (`data expiration (s)`, `Byzantine robots`).
    pub axis: String,
    /// The grid, in task order.
    pub points: Vec<Point>,
    /// The paper's runs per point.
    pub runs: u32,
}

/// Looks an experiment up by id (docs/SPEC.md section 7).
pub fn experiment(name: &str) -> anyhow::Result<Experiment> {
    match entry(name) {
        Some(entry) => Ok(entry.experiment()),
        None => anyhow::bail!(
            "unknown experiment {name:?}; the experiments are {}",
            EXPERIMENTS.join(", ")
        ),
    }
}

/// The grid of `e1-expiration`: data expiration 250 to 1250 s (`expiration-<s>`).
fn expiration_grid() -> Vec<Point> {
    [250u32, 500, 750, 1000, 1250]
        .iter()
        .map(|&s| Point {
            name: format!("expiration-{s}"),
            x: f64::from(s),
            overrides: vec![format!("data.expiration_s={s}.0")],
            tags: Vec::new(),
        })
        .collect()
}

/// The one point of `e1-faulty`: its preset as it is (`faulty-1`).
fn faulty_point() -> Vec<Point> {
    vec![Point {
        name: "faulty-1".into(),
        x: 1.0,
        overrides: Vec::new(),
        tags: Vec::new(),
    }]
}

/// The grid of e2 and e3: 0 to 7 Byzantine robots of the preset's kind (`byzantine-<count>`).
fn byzantine_grid() -> Vec<Point> {
    (0..=7u32)
        .map(|count| Point {
            name: format!("byzantine-{count}"),
            x: f64::from(count),
            overrides: if count == 0 {
                // Validation requires kind none with count 0.
                vec!["byzantine.count=0".into(), "byzantine.kind=none".into()]
            } else {
                vec![format!("byzantine.count={count}")]
            },
            tags: Vec::new(),
        })
        .collect()
}

/// The grid of e2-malicious and e3-smart under the authors' contract (issue #36): the `authors`
/// preset (the paper's system with [`swarmfl_core::config::AUTHORS_CONTRACT`]) and the same
/// points, 0 to 7 robots of `kind`, so each point compares with its namesake of the paper's
/// experiment at the same seeds.
fn authors_grid(kind: ByzantineKind) -> Vec<Point> {
    let mut points = byzantine_grid();
    for p in points.iter_mut().filter(|p| p.x > 0.0) {
        p.overrides.push(format!("byzantine.kind={}", kind.name()));
    }
    points
}

/// The overrides that give a run the authors' gas limits: the EVM engine with
/// `contract.gas_limit = "estimate"` (web3.py's estimate plus 100,000).
pub const AUTHORS_GAS: [&str; 2] = ["contract.engine=evm", "contract.gas_limit=estimate"];

/// `e2-malicious-authors-gas` and `e3-smart-authors-gas`'s grid: [`authors_grid`] with the
/// authors' gas limits ([`AUTHORS_GAS`]) at every point.
fn authors_gas_grid(kind: ByzantineKind) -> Vec<Point> {
    let mut points = authors_grid(kind);
    for p in &mut points {
        p.overrides.extend(AUTHORS_GAS.map(String::from));
    }
    points
}

/// `e3-smart-authors-code`'s grid: [`authors_grid`] of smart robots forging as the authors'
/// code does (`byzantine.variant = "authors"`: 2 r Delta, the first submission extrapolated
/// from all-zero weights).
fn authors_code_grid() -> Vec<Point> {
    let mut points = authors_grid(ByzantineKind::Smart);
    for p in points.iter_mut().filter(|p| p.x > 0.0) {
        p.overrides.push("byzantine.variant=authors".into());
    }
    points
}

/// The aggregations the baselines experiment compares, in grid order.
pub const AGGREGATIONS: [&str; 3] = ["chain", "gossip", "central"];

/// The grid of `e0-baselines`: each aggregation (`chain` with security on) without Byzantine
/// robots, with one faulty robot and with three malicious ones. A point's name is
/// `<aggregation>-<condition>` and its x the number of Byzantine robots.
fn baselines_grid() -> Vec<Point> {
    let conditions: [(&str, u32, &[&str]); 3] = [
        ("clean", 0, &["byzantine.count=0", "byzantine.kind=none"]),
        (
            "faulty-1",
            1,
            &["byzantine.count=1", "byzantine.kind=faulty"],
        ),
        (
            "malicious-3",
            3,
            &["byzantine.count=3", "byzantine.kind=malicious"],
        ),
    ];
    AGGREGATIONS
        .iter()
        .flat_map(|aggregation| {
            conditions.iter().map(move |(condition, count, overrides)| {
                let mut all = vec![format!("learn.aggregation={aggregation}")];
                all.extend(overrides.iter().map(|o| o.to_string()));
                Point {
                    name: format!("{aggregation}-{condition}"),
                    x: f64::from(*count),
                    overrides: all,
                    tags: vec![
                        ("aggregation", aggregation.to_string()),
                        ("condition", condition.to_string()),
                    ],
                }
            })
        })
        .collect()
}

/// The grid of `e4-robustness`, rule-major: per rule its clean point (no Byzantine robot),
/// then every attack at every non-zero count of [`E4_COUNTS`]. Point names are
/// `<rule>--<attack>--<count>` (`paper--none--0`, `krum--alie--3`).
fn e4_points() -> Vec<Point> {
    let mut points = Vec::new();
    for rule in E4_RULES {
        let base = vec![
            format!("contract.rule={}", rule.name()),
            format!("contract.assumed_f={}", e4_assumed_f(rule)),
        ];
        for &count in &E4_COUNTS {
            let kinds: Vec<ByzantineKind> = if count == 0 {
                vec![ByzantineKind::None]
            } else {
                E4_ATTACKS.to_vec()
            };
            for kind in kinds {
                let mut overrides = base.clone();
                overrides.push(format!("byzantine.kind={}", kind.name()));
                overrides.push(format!("byzantine.count={count}"));
                points.push(Point {
                    name: format!("{}--{}--{count}", rule.name(), kind.name()),
                    x: f64::from(count),
                    overrides,
                    tags: vec![
                        ("rule", rule.name().to_string()),
                        ("attack", kind.name().to_string()),
                    ],
                });
            }
        }
    }
    points
}

/// The grid of `e4-benchmark`, behaviour-major, then rule-major: per behaviour and rule its
/// clean point, then every attack of [`BENCH_ATTACKS`] at every non-zero count of
/// [`BENCH_COUNTS`]; full-length runs (5000 s, the paper's). Point names are
/// `<behaviour>--<rule>--<attack>--<count>` (`mixed--nnm+krum--optimal-alie--3`).
fn bench_points() -> Vec<Point> {
    let mut points = Vec::new();
    for behaviour in BENCH_BEHAVIOURS {
        for (rule, nnm) in BENCH_RULES {
            let name = bench_rule_name(rule, nnm);
            let mut base = vec![
                "run.duration_s=5000.0".to_string(),
                format!("world.behaviour={}", behaviour.name()),
                format!("contract.rule={}", rule.name()),
                format!("contract.assumed_f={}", e4_assumed_f(rule)),
            ];
            if nnm {
                base.push("contract.preaggregators=[\"nnm\"]".to_string());
            }
            for &count in &BENCH_COUNTS {
                let kinds: &[ByzantineKind] = if count == 0 {
                    &[ByzantineKind::None]
                } else {
                    &BENCH_ATTACKS
                };
                for &kind in kinds {
                    let mut overrides = base.clone();
                    overrides.push(format!("byzantine.kind={}", kind.name()));
                    overrides.push(format!("byzantine.count={count}"));
                    points.push(Point {
                        name: format!("{}--{name}--{}--{count}", behaviour.name(), kind.name()),
                        x: f64::from(count),
                        overrides,
                        tags: vec![
                            ("behaviour", behaviour.name().to_string()),
                            ("rule", name.clone()),
                            ("attack", kind.name().to_string()),
                        ],
                    });
                }
            }
        }
    }
    points
}

/// The grid of `e4-gate`: `e4-benchmark`'s points for the rules of [`GATE_RULES`] at 0 and 5
/// Byzantine robots (the count at which every robust rule lost runs and the paper's rule
/// lost fewest), each behind the paper's threshold, same preset, seeds and settings, so each
/// point compares with its `e4-benchmark` namesake without the gate. Point names are
/// `<behaviour>--gate+<rule>--<attack>--<count>`.
fn gate_points() -> Vec<Point> {
    bench_points()
        .into_iter()
        .filter(|p| {
            let rule = p
                .tags
                .iter()
                .find(|(k, _)| *k == "rule")
                .map(|(_, v)| v.as_str());
            GATE_RULES.iter().any(|r| rule == Some(r.name())) && (p.x == 0.0 || p.x == 5.0)
        })
        .map(|mut p| {
            for (k, v) in &mut p.tags {
                if *k == "rule" {
                    *v = format!("gate+{v}");
                }
            }
            let mut parts: Vec<&str> = p.name.split("--").collect();
            let gated = format!("gate+{}", parts[1]);
            parts[1] = &gated;
            p.name = parts.join("--");
            p.overrides.push("contract.threshold_gate=true".to_string());
            p
        })
        .collect()
}

/// Counts of `smart-then-collude` in `e5-smart-defence`: 3 (a minority that must first earn
/// a majority of the tokens), 5 and 7 (the paper's "from 3 on" up to the largest minority).
pub const E5_SWITCH_COUNTS: [u32; 3] = [3, 5, 7];

/// The grid of `e5-smart-defence`, defence-major (`none`, `agreement`, `innovation`): the
/// e3-smart grid (`smart` x 0..7), `smart-then-collude` x [`E5_SWITCH_COUNTS`], and the e2
/// check (`faulty` and `malicious` x 3). Point names are `<defence>--<attack>--<count>`
/// (`agreement--smart--3`, `none--none--0`).
fn e5_points() -> Vec<Point> {
    let mut points = Vec::new();
    for defence in Defence::ALL {
        let mut grid: Vec<(ByzantineKind, u32)> = vec![(ByzantineKind::None, 0)];
        grid.extend((1..=7).map(|count| (ByzantineKind::Smart, count)));
        grid.extend(
            E5_SWITCH_COUNTS
                .iter()
                .map(|&count| (ByzantineKind::SmartThenCollude, count)),
        );
        grid.push((ByzantineKind::Faulty, 3));
        grid.push((ByzantineKind::Malicious, 3));
        for (kind, count) in grid {
            points.push(Point {
                name: format!("{}--{}--{count}", defence.name(), kind.name()),
                x: f64::from(count),
                overrides: vec![
                    format!("contract.defence={}", defence.name()),
                    format!("byzantine.kind={}", kind.name()),
                    format!("byzantine.count={count}"),
                ],
                tags: vec![
                    ("defence", defence.name().to_string()),
                    ("attack", kind.name().to_string()),
                ],
            });
        }
    }
    debug_assert!(points
        .iter()
        .all(|p| Defence::from_name(&p.tags[0].1).is_some()));
    points
}

/// The home ranges' concentrations of `e4-heterogeneity-measure`, from roaming (`inf`, the
/// paper's walk) to few regions per robot; a point's x is its place in this list.
pub const HETEROGENEITY_ALPHAS: [&str; 5] = ["inf", "10", "1", "0.3", "0.1"];

/// The swarm sizes of `e4-heterogeneity-measure`, at the paper's density ([`paper_density`]).
pub const HETEROGENEITY_SIZES: [u32; 2] = [15, 60];

/// The grid of `e4-heterogeneity-measure` (issue 55): every size of [`HETEROGENEITY_SIZES`] x
/// alpha of [`HETEROGENEITY_ALPHAS`] (`alpha-<alpha>-<robots>`), 3600 s world-only runs: a
/// minimum of training samples no data set reaches makes every robot skip every phase, so
/// nothing trains and the ledger carries no model, while `world.position_heterogeneity`
/// measures the data each robot would have trained on at each phase.
fn heterogeneity_measure_points() -> Vec<Point> {
    let mut points = Vec::new();
    for robots in HETEROGENEITY_SIZES {
        for (i, alpha) in HETEROGENEITY_ALPHAS.iter().enumerate() {
            let mut overrides = paper_density(robots);
            overrides.push(format!("world.home_range.alpha={alpha}"));
            overrides.push("run.duration_s=3600".into());
            overrides.push("learn.min_train_samples=1000000".into());
            points.push(Point {
                name: format!("alpha-{alpha}-{robots}"),
                x: i as f64,
                overrides,
                tags: vec![("alpha", alpha.to_string()), ("robots", robots.to_string())],
            });
        }
    }
    points
}

/// One task: a configuration point and a seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Task {
    /// Position in the experiment's task list: `point_index * runs + (seed - 1)`.
    pub index: usize,
    /// The experiment's id (its results' directory name).
    pub experiment: String,
    /// Index of the point in the experiment's grid.
    pub point_index: usize,
    /// The point's name.
    pub point: String,
    /// The seed, `1..=runs`.
    pub seed: u64,
    /// All overrides: the point's, then the sweep's `--set` ones.
    pub overrides: Vec<String>,
}

/// Expands an experiment into its task list (point-major, seeds `1..=runs`), with `extra`
/// overrides appended to every task.
pub fn tasks(exp: &Experiment, runs: u32, extra: &[String]) -> Vec<Task> {
    let mut out = Vec::with_capacity(exp.points.len() * runs as usize);
    for (p, point) in exp.points.iter().enumerate() {
        for seed in 1..=u64::from(runs) {
            let mut overrides = point.overrides.clone();
            overrides.extend(extra.iter().cloned());
            out.push(Task {
                index: out.len(),
                experiment: exp.name.clone(),
                point_index: p,
                point: point.name.clone(),
                seed,
                overrides,
            });
        }
    }
    assert!(out
        .iter()
        .all(|t| t.index == t.point_index * runs as usize + (t.seed as usize - 1)));
    out
}

#[cfg(test)]
mod tests;

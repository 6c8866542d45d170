//! The configuration types of the robots' behaviours (`world.behaviour`, `world.mixed`,
//! `world.flocking`, `world.foraging`), of the avoidance walk's home ranges
//! (`world.home_range`), of the obstacle-avoidance rule (`world.avoidance`) and of the
//! trajectory window rule (`data.window_rule`).
//! Their behaviour lives in `world/` (one controller a file) and `data.rs`; docs/SPEC.md
//! section 1 has every value beside Flow-FL's.

use serde::{Deserialize, Serialize};

registry! {
    /// What a robot does: the controller that drives it.
    #[derive(
        Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
    )]
    #[serde(rename_all = "lowercase")]
    pub enum Behaviour {
        /// Random walk at cruise speed with obstacle avoidance (the paper's robots; today's
        /// default).
        #[default]
        Avoidance = "avoidance",
        /// Separation, cohesion and alignment from the range-and-bearing readings of neighbours,
        /// steered toward a goal (Flow-FL's flocking to a light).
        Flocking = "flocking",
        /// Shuttling between food sources and the nest: explore, return with an item, rest.
        Foraging = "foraging",
        /// A swarm whose robots run different behaviours (`world.mixed`).
        Mixed = "mixed",
    }
}

/// How the robots of a `mixed` swarm get their behaviours.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MixedConfig {
    /// Share of the swarm that runs avoidance; robot `i` gets the behaviour whose cumulative
    /// share first exceeds `(i + 0.5) / robots` (avoidance, then flocking, then foraging), so
    /// the split is exact up to rounding and needs no random draw. The three must sum to 1.
    pub avoidance: f64,
    /// Share that runs flocking.
    pub flocking: f64,
    /// Share that runs foraging.
    pub foraging: f64,
    /// One behaviour per robot (`avoidance`, `flocking` or `foraging`), overriding the shares
    /// when not empty; it must name every robot.
    pub per_robot: Vec<Behaviour>,
    /// How robots get their behaviours: `share` (by robot index, from the shares or
    /// `per_robot`, for the whole run) or `place` (Flow-FL's `mixed_by_location`: each tick by
    /// where the robot is, `world/place.rs`; the shares and `per_robot` are not read). Left out
    /// of the recorded text at its default, `share`.
    #[serde(default, skip_serializing_if = "is_share")]
    pub assign: MixedAssign,
}

/// How a mixed swarm's robots get their behaviours (`world.mixed.assign`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MixedAssign {
    /// One behaviour per robot for the whole run, by index (`world.mixed.avoidance`,
    /// `flocking`, `foraging`, or `per_robot`): what records without the key ran.
    #[default]
    Share,
    /// By place, each tick (Flow-FL's `khepera_mixed.cpp`, `ControlStep`): flocking beyond
    /// |x| = 2 m, avoidance where y > 0, foraging elsewhere (`world/place.rs`).
    Place,
}

impl MixedAssign {
    /// The name used in configurations.
    pub fn name(self) -> &'static str {
        match self {
            MixedAssign::Share => "share",
            MixedAssign::Place => "place",
        }
    }
}

fn is_share(assign: &MixedAssign) -> bool {
    super::skip::omit(*assign == MixedAssign::Share)
}

/// How far from the arena's center the place rule's layout reaches, in metres: its flockers
/// steer to goals at y = -2.5 and +2.5 m, beyond the flocking bands |x| > 2 m
/// (`world/place.rs`, Flow-FL's `khepera_mixed.cpp` in its +-3 m arena), so
/// `world.mixed.assign = "place"` needs an arena of at least 2 x (2.5 m + a robot's radius).
pub const PLACE_LAYOUT_HALF_M: f64 = 2.5;

impl Default for MixedConfig {
    fn default() -> Self {
        MixedConfig {
            avoidance: 1.0 / 3.0,
            flocking: 1.0 / 3.0,
            foraging: 1.0 / 3.0,
            per_robot: Vec::new(),
            assign: MixedAssign::Share,
        }
    }
}

impl MixedConfig {
    /// Robot `robot`'s behaviour in a swarm of `robots` (never `Mixed`) under `assign =
    /// "share"` (under `"place"` the world assigns behaviours from positions instead,
    /// `world/place.rs`).
    pub fn behaviour_of(&self, robot: u32, robots: u32) -> Behaviour {
        if let Some(&b) = self.per_robot.get(robot as usize) {
            return b;
        }
        let at = (f64::from(robot) + 0.5) / f64::from(robots.max(1));
        if at < self.avoidance {
            Behaviour::Avoidance
        } else if at < self.avoidance + self.flocking {
            Behaviour::Flocking
        } else {
            Behaviour::Foraging
        }
    }
}

/// Flocking: the parameters of the heading rule (world/flocking.rs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlockingConfig {
    /// Preferred distance to a neighbour in metres (Flow-FL: 75 cm); closer repels, farther
    /// attracts (a generalised Lennard-Jones potential of exponent 2).
    pub target_distance_m: f64,
    /// Weight of the separation/cohesion term (its length is clamped to 1 before weighting).
    pub cohesion_weight: f64,
    /// Weight of the alignment term: the mean heading of the neighbours heard.
    pub alignment_weight: f64,
    /// Weight of the pull toward the goal (Flow-FL: the light).
    pub goal_weight: f64,
    /// The goal's x in metres (Flow-FL's light: -2 m of a 4 m arena, i.e. near the west wall).
    pub goal_x_m: f64,
    /// The goal's y in metres (Flow-FL's light: -1.5 m).
    pub goal_y_m: f64,
    /// Period in seconds after which the goal moves to its mirror image through the arena's
    /// center (0 = a fixed goal, as Flow-FL's light), so the flock keeps travelling.
    pub goal_swap_s: f64,
}

impl Default for FlockingConfig {
    fn default() -> Self {
        FlockingConfig {
            target_distance_m: 0.75,
            cohesion_weight: 1.0,
            alignment_weight: 0.5,
            goal_weight: 1.0,
            goal_x_m: -1.5,
            goal_y_m: -1.0,
            goal_swap_s: 200.0,
        }
    }
}

/// Foraging: the nest, the food sources and the state machine's times (world/foraging.rs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForagingConfig {
    /// The nest's center x in metres (Flow-FL: the west strip of the arena, by its lights).
    pub nest_x_m: f64,
    /// The nest's center y in metres.
    pub nest_y_m: f64,
    /// The nest's radius in metres; it must lie inside the arena's walls.
    pub nest_radius_m: f64,
    /// Number of food sources, placed from the seed (`Purpose::Obstacles`' stream, after the
    /// obstacles) inside the walls, clear of the nest and of the obstacles.
    pub food_sources: u32,
    /// Radius of a food source in metres (Flow-FL's items: 0.1 m).
    pub food_radius_m: f64,
    /// Seconds a robot rests in the nest after delivering an item before exploring again
    /// (`simple` rule only).
    pub rest_s: f64,
    /// The foraging controller: `simple` (ours, `world/foraging.rs`) or `flowfl` (Flow-FL's
    /// `khepera_foraging` and its arena, `world/foraging_flowfl.rs`: the nest is the strip
    /// x < -1 m lit by four lights on the west wall, items are picked up where they lie and
    /// re-placed when delivered, rest and exploration end with probabilities; the nest keys
    /// and `rest_s` are not read). Left out of the recorded text at its default.
    #[serde(default, skip_serializing_if = "is_simple")]
    pub rule: ForagingRule,
    /// Food sources per robot: when above 0, the arena holds `food_per_robot x world.robots`
    /// sources in place of `food_sources` (Flow-FL: 2, its `FOOD_FACTOR`). Left out of the
    /// recorded text at 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub food_per_robot: u32,
}

impl ForagingConfig {
    /// The number of food sources in a swarm of `robots`.
    pub fn food_count(&self, robots: u32) -> u32 {
        if self.food_per_robot > 0 {
            self.food_per_robot.saturating_mul(robots)
        } else {
            self.food_sources
        }
    }
}

/// How far from the arena's center Flow-FL's foraging layout reaches, in metres: its items
/// lie in [-0.9, 1.7] x [-1.7, 1.7] (`foraging_loop_functions.cpp`), so `rule = "flowfl"` needs
/// an arena of at least 2 x (1.7 m + a robot's radius).
pub const FLOWFL_LAYOUT_HALF_M: f64 = 1.7;

/// Which foraging controller the foragers run (`world.foraging.rule`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ForagingRule {
    /// Ours (`world/foraging.rs`): a nest disk, fixed sources, a fixed rest.
    #[default]
    Simple,
    /// Flow-FL's (`world/foraging_flowfl.rs`, the `flowfl-foraging` preset).
    Flowfl,
}

impl ForagingRule {
    /// The name used in configurations.
    pub fn name(self) -> &'static str {
        match self {
            ForagingRule::Simple => "simple",
            ForagingRule::Flowfl => "flowfl",
        }
    }
}

fn is_simple(rule: &ForagingRule) -> bool {
    super::skip::omit(*rule == ForagingRule::Simple)
}

fn is_zero(n: &u32) -> bool {
    super::skip::omit(*n == 0)
}

impl Default for ForagingConfig {
    fn default() -> Self {
        ForagingConfig {
            nest_x_m: -1.4,
            nest_y_m: 0.0,
            nest_radius_m: 0.5,
            food_sources: 4,
            food_radius_m: 0.15,
            rest_s: 10.0,
            rule: ForagingRule::Simple,
            food_per_robot: 0,
        }
    }
}

/// Home ranges of the avoidance walk (`world.home_range`, `world/home_range.rs`): the arena is
/// split into a square grid of `regions` regions; each robot draws a preference vector over
/// them from a Dirichlet(`alpha`) in its own stream (`Purpose::HomeRange`) and, every
/// `goal_period_s`, picks a region from it; outside that region its walk steers toward the
/// region's centre, obstacle avoidance first. `alpha = "inf"` (the default) is no pull at all:
/// today's roaming swarm. The whole table is left out of the recorded text at its default, so
/// records without it keep their hashes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HomeRangeConfig {
    /// Number of regions, a square grid over the arena (1, 4, 9, 16, ...; default 9). With the
    /// knob on, each region's side (`arena_side_m / sqrt(regions)`) must be at least two robot
    /// diameters ([`MIN_REGION_DIAMETERS`]).
    pub regions: u32,
    /// The Dirichlet concentration of each robot's preferences over the regions: `"inf"` (the
    /// default: no home range, today's roaming swarm) or a positive number; small values (0.1)
    /// confine each robot to one or two regions, large ones spread it over all of them. Read
    /// from TOML as `inf`, `"inf"` or a number.
    pub alpha: f64,
    /// Seconds between two picks of a robot's current region from its preferences (default
    /// 60 s: a region of the paper's 3 x 3 grid is 1.67 m wide, about 67 s at its cruise
    /// speed of 2.5 cm/s, so a robot can reach the region it picked before it picks again).
    pub goal_period_s: f64,
}

/// The smallest side of a home-range region, in robot diameters: a robot must be able to turn
/// and pass another inside its region.
pub const MIN_REGION_DIAMETERS: f64 = 2.0;

impl Default for HomeRangeConfig {
    fn default() -> Self {
        HomeRangeConfig {
            regions: 9,
            alpha: f64::INFINITY,
            goal_period_s: 60.0,
        }
    }
}

impl HomeRangeConfig {
    /// Whether robots have home ranges (a finite `alpha`); off, the walk is today's.
    pub fn is_on(&self) -> bool {
        self.alpha.is_finite()
    }

    /// The grid's side in regions (`sqrt(regions)`), if `regions` is a positive perfect
    /// square.
    pub fn side(&self) -> Option<u32> {
        let k = (1..=self.regions).find(|k| k.saturating_mul(*k) >= self.regions)?;
        (k * k == self.regions).then_some(k)
    }
}

/// When a window of consecutive readings of one neighbour becomes a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WindowRule {
    /// At its `trajectory_ticks`-th reading; the next window starts at the next reading, and a
    /// missed tick discards the window (ours before #38; what records without the key ran).
    #[default]
    Contiguous,
    /// The authors' code (Flow-FL's `trajectory_collection_loop_functions.cpp` and
    /// geth-argos' `main.py`, same logic): a full window is saved only when the neighbour is
    /// heard again on the next tick, and that reading starts nothing; a gap is noticed at the
    /// next reading of that neighbour, which is dropped too.
    Confirmed,
}

impl WindowRule {
    /// The name used in configurations.
    pub fn name(self) -> &'static str {
        match self {
            WindowRule::Contiguous => "contiguous",
            WindowRule::Confirmed => "confirmed",
        }
    }
}

/// How robots sense and avoid obstacles (`world.avoidance`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Avoidance {
    /// Ours until issue #38: sensors evenly spaced from the heading, reading `1 - d / range`;
    /// a front reading above `world.proximity_threshold` makes the robot turn in place, in
    /// the same direction until the front is clear (`world/steering.rs`).
    #[default]
    Turn,
    /// The paper's code on ARGoS's e-puck (`world/epuck.rs`): the e-puck proximity ring
    /// (8 sensors from 11.25 degrees, 1 mm off the body, ARGoS's calibrated reading curve, 0
    /// beyond 5 cm) and geth-argos' `RandomWalk.avoid`: every sensor above the threshold adds
    /// its weight times its reading to one wheel and takes it from the other, around half the
    /// cruise speed, saturated at the cruise speed. Needs `world.proximity_sensors = 8`.
    Epuck,
    /// Flow-FL's robots (`world/khepera.rs`): ARGoS's Khepera IV proximity ring (8 sensors
    /// from the heading, rays from the body surface, its calibrated curve, 0 from 11.8 cm)
    /// and Flow-FL's `khepera_obstacleavoidance` controller: when the largest of the readings
    /// at 0, 45, -45 and -90 degrees is above the threshold, the robot pivots on one wheel
    /// away from it. Needs `world.proximity_sensors = 8`.
    Khepera,
}

impl Avoidance {
    /// The name used in configurations.
    pub fn name(self) -> &'static str {
        match self {
            Avoidance::Turn => "turn",
            Avoidance::Epuck => "epuck",
            Avoidance::Khepera => "khepera",
        }
    }
}

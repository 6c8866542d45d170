//! Which robot runs which behaviour, and the part of the reduced state that behaviours add:
//! the foraging arena (nest, food sources) and each forager's state (docs/SPEC.md section 1,
//! "Behaviours").
//!
//! The assignment is a pure function of the configuration (`world.behaviour`, and for
//! `mixed` the shares or the per-robot list of `world.mixed`) or, with `world.mixed.assign =
//! "place"`, of the robots' positions (`place.rs`, redone by the reducer after every tick), so
//! the world and the controllers agree on it without a random draw: the controllers read it
//! from the world. Food sources are placed from their own
//! seeded stream (`Purpose::Obstacles`, index 1), so they never perturb the obstacles' or the
//! robots' placement. Forager states ([`Forager`]) change in the reducer, from positions
//! alone (`foraging.rs`): replaying the tick events reproduces them, and they enter the world's
//! digest, so every checkpoint covers them.

use serde::{Deserialize, Serialize};

use super::arena::{Arena, PLACEMENT_ATTEMPTS};
use super::foraging_flowfl::FlowflForaging;
use super::{place, Pose, WorldError};
use crate::config::{Behaviour, Config, ForagingRule, MixedAssign};
use crate::rng::{self, Purpose};

/// Each robot's behaviour (never `Mixed`) with the robots at `poses`, in robot order.
pub fn assignment(config: &Config, poses: &[Pose]) -> Vec<Behaviour> {
    let w = &config.world;
    if assigned_by_place(config) {
        return poses
            .iter()
            .map(|p| place::behaviour_at(p.x, p.y))
            .collect();
    }
    (0..w.robots)
        .map(|i| match w.behaviour {
            Behaviour::Mixed => w.mixed.behaviour_of(i, w.robots),
            b => b,
        })
        .collect()
}

/// Whether the behaviours follow the robots' places (`world.mixed.assign = "place"` in a mixed
/// swarm), each tick, instead of being fixed per robot.
pub fn assigned_by_place(config: &Config) -> bool {
    let w = &config.world;
    w.behaviour == Behaviour::Mixed && w.mixed.assign == MixedAssign::Place
}

/// The nest of a foraging swarm: a disk robots bring items to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Nest {
    /// Center x in metres.
    pub x: f64,
    /// Center y in metres.
    pub y: f64,
    /// Radius in metres.
    pub radius_m: f64,
}

impl Nest {
    /// Whether the point lies in the nest.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        (x - self.x) * (x - self.x) + (y - self.y) * (y - self.y) <= self.radius_m * self.radius_m
    }
}

/// A food source: a disk where an exploring robot picks an item up (sources never run out).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Food {
    /// Center x in metres.
    pub x: f64,
    /// Center y in metres.
    pub y: f64,
}

/// A forager's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Forager {
    /// Looking for food (the avoidance walk).
    Explore,
    /// Carrying an item to the nest.
    Return,
    /// Resting in the nest until the given tick.
    Rest {
        /// The tick at which it explores again.
        until: u64,
    },
}

impl Forager {
    /// A short name for drawings and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Forager::Explore => "explore",
            Forager::Return => "return",
            Forager::Rest { .. } => "rest",
        }
    }
}

/// The behaviours' part of the world.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Behaviours {
    /// Each robot's behaviour, in robot order (this tick's, under the place rule).
    pub of: Vec<Behaviour>,
    /// How `of` is set: `Place` redoes it from the positions after every tick (`place.rs`).
    /// Left out of the serialized state at `Share`.
    #[serde(default, skip_serializing_if = "is_share")]
    pub assign: MixedAssign,
    /// The nest, when some robot forages.
    pub nest: Option<Nest>,
    /// The food sources (empty without foragers).
    pub food: Vec<Food>,
    /// Radius of every food source in metres.
    pub food_radius_m: f64,
    /// Ticks a forager rests in the nest.
    pub rest_ticks: u64,
    /// Each robot's foraging state (`Explore` for robots that do not forage).
    pub foragers: Vec<Forager>,
    /// Items ever delivered to the nest, all robots.
    pub deliveries: u64,
    /// Flow-FL's foraging (`world.foraging.rule = "flowfl"`, `foraging_flowfl.rs`): its
    /// foragers' states and its items; then `nest` is `None` and `food` empty. Left out of the
    /// serialized state under the `simple` rule.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flowfl: Option<FlowflForaging>,
}

impl Behaviours {
    /// The behaviours of the run seeded with `seed` with the robots at `poses`, or `None`
    /// when every robot runs the default avoidance walk for the whole run (then the world is
    /// exactly what it was before behaviours).
    pub fn new(
        config: &Config,
        seed: u64,
        arena: &Arena,
        poses: &[Pose],
    ) -> Result<Option<Behaviours>, WorldError> {
        let of = assignment(config, poses);
        let by_place = assigned_by_place(config);
        if !by_place && of.iter().all(|&b| b == Behaviour::Avoidance) {
            return Ok(None);
        }
        let assign = if by_place {
            MixedAssign::Place
        } else {
            MixedAssign::Share
        };
        let f = &config.world.foraging;
        // Under the place rule any robot may forage, whatever it does at the start.
        let foraging = by_place || of.contains(&Behaviour::Foraging);
        if foraging && f.rule == ForagingRule::Flowfl {
            let forages = of.iter().map(|&b| b == Behaviour::Foraging).collect();
            return Ok(Some(Behaviours {
                foragers: of
                    .iter()
                    .map(|&b| match b {
                        Behaviour::Foraging => Forager::Rest { until: 0 },
                        _ => Forager::Explore,
                    })
                    .collect(),
                of,
                assign,
                nest: None,
                food: Vec::new(),
                food_radius_m: f.food_radius_m,
                rest_ticks: 0,
                deliveries: 0,
                flowfl: Some(FlowflForaging::new(config, seed, forages)),
            }));
        }
        let nest = foraging.then_some(Nest {
            x: f.nest_x_m,
            y: f.nest_y_m,
            radius_m: f.nest_radius_m,
        });
        let food = match nest {
            Some(nest) => place_food(config, seed, arena, &nest)?,
            None => Vec::new(),
        };
        Ok(Some(Behaviours {
            foragers: vec![Forager::Explore; of.len()],
            of,
            assign,
            nest,
            food,
            food_radius_m: f.food_radius_m,
            rest_ticks: (f.rest_s / config.run.tick_s).round() as u64,
            deliveries: 0,
            flowfl: None,
        }))
    }

    /// Under the place rule, sets every robot's behaviour from the positions after a tick.
    pub(super) fn follow_places(&mut self, poses: &[Pose]) {
        if self.assign == MixedAssign::Place {
            place::assign(&mut self.of, poses);
        }
    }

    /// Whether a robot at (`x`, `y`) with body radius `r` touches a food source.
    pub fn at_food(&self, x: f64, y: f64, r: f64) -> bool {
        let reach = self.food_radius_m + r;
        self.food
            .iter()
            .any(|s| (x - s.x) * (x - s.x) + (y - s.y) * (y - s.y) <= reach * reach)
    }
}

fn is_share(assign: &MixedAssign) -> bool {
    *assign == MixedAssign::Share
}

/// Food sources uniformly inside the walls, each clear of the nest and of every obstacle by a
/// robot's diameter (so a robot can reach it), and of the other sources.
fn place_food(
    config: &Config,
    seed: u64,
    arena: &Arena,
    nest: &Nest,
) -> Result<Vec<Food>, WorldError> {
    let f = &config.world.foraging;
    let r = config.world.robot_radius_m;
    let fr = f.food_radius_m;
    let lim = arena.half_side_m - fr - 2.0 * r;
    let mut rng = rng::stream(seed, Purpose::Obstacles, 1);
    let count = f.food_count(config.world.robots);
    let mut food: Vec<Food> = Vec::with_capacity(count as usize);
    for k in 0..count {
        let mut placed = None;
        for _ in 0..PLACEMENT_ATTEMPTS {
            if lim <= 0.0 {
                break;
            }
            let (x, y) = (rng.range(-lim, lim), rng.range(-lim, lim));
            let clear_of_nest = libm::hypot(x - nest.x, y - nest.y) > nest.radius_m + fr;
            let clear_of_food = food
                .iter()
                .all(|s| libm::hypot(x - s.x, y - s.y) > 2.0 * fr);
            let reach = fr + 2.0 * r;
            let clear_of_obstacles = arena
                .obstacles
                .iter()
                .all(|o| o.distance_sq(x, y) > reach * reach);
            if clear_of_nest && clear_of_food && clear_of_obstacles {
                placed = Some(Food { x, y });
                break;
            }
        }
        let Some(source) = placed else {
            return Err(WorldError::Placement {
                what: format!("food source {k}"),
                why: format!(
                    "no spot clear of the nest, the obstacles and the other sources after \
                     {PLACEMENT_ATTEMPTS} attempts: {count} sources (world.foraging.food_sources, \
                     or world.foraging.food_per_robot x world.robots) of \
                     world.foraging.food_radius_m = {} do not fit in world.arena_side_m = {}; \
                     use fewer or smaller sources, a smaller nest or a larger arena",
                    fr, config.world.arena_side_m
                ),
            });
        };
        food.push(source);
    }
    Ok(food)
}

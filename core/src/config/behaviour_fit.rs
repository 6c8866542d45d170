//! The checks of the robots' behaviours (`world.*`) that relate several keys, rows of the
//! validation table in `validate.rs`: the proximity ring an avoidance rule reads, a mixed swarm's
//! shares or places, and the flocking and foraging layouts that must fit inside the arena. Each
//! runs only when some robot runs its behaviour ([`runs`]).

use super::behaviour::{
    Avoidance, Behaviour, ForagingRule, MixedAssign, MIN_REGION_DIAMETERS, PLACE_LAYOUT_HALF_M,
};
use super::error::ConfigError;
use super::ranges::{integer, number, out_of_range, positive};
use super::tree::Config;
use crate::types::show_f64;

/// `world.avoidance = "epuck"` weighs the e-puck's eight sensors one by one, and `"khepera"`
/// reads four of the Khepera IV's eight by index.
pub(super) fn ring_rules_have_eight_sensors(c: &Config) -> Result<(), ConfigError> {
    let w = &c.world;
    if w.avoidance != Avoidance::Turn && w.proximity_sensors != 8 {
        return out_of_range(
            "world.proximity_sensors",
            w.proximity_sensors.to_string(),
            format!(
                "8 with world.avoidance = \"{}\" (the robot's ring and its rule); set world.proximity_sensors=8 or world.avoidance=turn",
                w.avoidance.name()
            ),
        );
    }
    Ok(())
}

/// Whether any robot of the swarm runs `b` (directly or in a mixed swarm; by place, every
/// robot may run every behaviour).
fn runs(c: &Config, b: Behaviour) -> bool {
    let w = &c.world;
    w.behaviour == b
        || (w.behaviour == Behaviour::Mixed
            && (w.mixed.assign == MixedAssign::Place
                || (0..w.robots).any(|i| w.mixed.behaviour_of(i, w.robots) == b)))
}

/// A mixed swarm's assignment is whole: a per-robot list only under `world.behaviour =
/// "mixed"` and then one entry per robot, by place what [`mixed_by_place_fits`] asks, otherwise
/// three shares in `[0, 1]` that sum to 1.
pub(super) fn mixed_swarm_is_complete(c: &Config) -> Result<(), ConfigError> {
    let w = &c.world;
    let m = &w.mixed;
    if !m.per_robot.is_empty() && w.behaviour != Behaviour::Mixed {
        return out_of_range(
            "world.mixed.per_robot",
            format!("{} entries", m.per_robot.len()),
            format!(
                "empty unless world.behaviour = \"mixed\" (it is \"{}\"); set world.behaviour=mixed",
                w.behaviour.name()
            ),
        );
    }
    if m.assign == MixedAssign::Place {
        return mixed_by_place_fits(c);
    }
    if w.behaviour != Behaviour::Mixed {
        return Ok(());
    }
    if !m.per_robot.is_empty() {
        if m.per_robot.len() != w.robots as usize {
            return out_of_range(
                "world.mixed.per_robot",
                format!("{} entries", m.per_robot.len()),
                format!(
                    "one behaviour per robot: {} entries (world.robots)",
                    w.robots
                ),
            );
        }
        if let Some(i) = m.per_robot.iter().position(|&b| b == Behaviour::Mixed) {
            return out_of_range(
                "world.mixed.per_robot",
                format!("\"mixed\" at index {i}"),
                "avoidance, flocking or foraging for each robot".to_string(),
            );
        }
        return Ok(());
    }
    for (key, v) in [
        ("world.mixed.avoidance", m.avoidance),
        ("world.mixed.flocking", m.flocking),
        ("world.mixed.foraging", m.foraging),
    ] {
        number(key, v, 0.0, 1.0)?;
    }
    let sum = m.avoidance + m.flocking + m.foraging;
    if (sum - 1.0).abs() > 1e-6 {
        return out_of_range(
            "world.mixed",
            format!(
                "avoidance {} + flocking {} + foraging {} = {sum}",
                m.avoidance, m.flocking, m.foraging
            ),
            "fractions that sum to 1 (e.g. --set world.mixed.avoidance=0.5 --set \
             world.mixed.flocking=0.25 --set world.mixed.foraging=0.25)"
                .to_string(),
        );
    }
    Ok(())
}

/// `world.mixed.assign = "place"` (`world/place.rs`): a mixed swarm, no per-robot list (the
/// place decides), our own foragers (Flow-FL's `flowfl` foraging lays out its own nest and
/// lights for the foraging arena), and an arena that holds the flocking bands' goals at
/// y = +-2.5 m with a robot's body to spare.
fn mixed_by_place_fits(c: &Config) -> Result<(), ConfigError> {
    let w = &c.world;
    let place = "with world.mixed.assign = \"place\"";
    if w.behaviour != Behaviour::Mixed {
        return out_of_range(
            "world.mixed.assign",
            "\"place\"".to_string(),
            format!(
                "\"share\" unless world.behaviour = \"mixed\" (it is \"{}\"); set world.behaviour=mixed",
                w.behaviour.name()
            ),
        );
    }
    if !w.mixed.per_robot.is_empty() {
        return out_of_range(
            "world.mixed.per_robot",
            format!("{} entries", w.mixed.per_robot.len()),
            format!("empty {place} (a robot's place sets its behaviour); set world.mixed.assign=share to list them"),
        );
    }
    if w.foraging.rule == ForagingRule::Flowfl {
        return out_of_range(
            "world.foraging.rule",
            "\"flowfl\"".to_string(),
            format!("\"simple\" {place} (Flow-FL's foraging is laid out for its foraging arena)"),
        );
    }
    let need = 2.0 * (PLACE_LAYOUT_HALF_M + w.robot_radius_m);
    if w.arena_side_m >= need {
        return Ok(());
    }
    out_of_range(
        "world.arena_side_m",
        show_f64(w.arena_side_m),
        format!(
            "at least {need} m {place} (Flow-FL's mixed arena: flocking beyond |x| = 2 m toward \
             goals at y = +-2.5 m); enlarge the arena or set world.mixed.assign=share"
        ),
    )
}

/// The largest |coordinate| of a point inside the walls, keeping `margin` from them.
fn inside(c: &Config, key: &str, value: f64, margin: f64) -> Result<(), ConfigError> {
    let half = c.world.arena_side_m / 2.0 - margin;
    if value.is_finite() && value.abs() <= half {
        return Ok(());
    }
    out_of_range(
        key,
        show_f64(value),
        format!("inside the arena: |value| <= world.arena_side_m / 2 - {margin} = {half} m"),
    )
}

/// The flocking weights and distances are in range and its goal lies inside the walls (when
/// some robot flocks).
pub(super) fn flocking_fits_the_arena(c: &Config) -> Result<(), ConfigError> {
    if !runs(c, Behaviour::Flocking) {
        return Ok(());
    }
    let f = &c.world.flocking;
    positive(
        "world.flocking.target_distance_m",
        f.target_distance_m,
        100.0,
    )?;
    number(
        "world.flocking.cohesion_weight",
        f.cohesion_weight,
        0.0,
        1.0e6,
    )?;
    number(
        "world.flocking.alignment_weight",
        f.alignment_weight,
        0.0,
        1.0e6,
    )?;
    number("world.flocking.goal_weight", f.goal_weight, 0.0, 1.0e6)?;
    number("world.flocking.goal_swap_s", f.goal_swap_s, 0.0, 1.0e9)?;
    inside(c, "world.flocking.goal_x_m", f.goal_x_m, 0.0)?;
    inside(c, "world.flocking.goal_y_m", f.goal_y_m, 0.0)
}

/// The foraging layout (nest, food count and size, rest) fits the arena (when some robot
/// forages); Flow-FL's own layout is [`flowfl_foraging_fits_the_arena`]'s.
pub(super) fn foraging_fits_the_arena(c: &Config) -> Result<(), ConfigError> {
    if !runs(c, Behaviour::Foraging) {
        return Ok(());
    }
    let f = &c.world.foraging;
    integer(
        "world.foraging.food_per_robot",
        f.food_per_robot.into(),
        0,
        100,
    )?;
    if f.rule == ForagingRule::Flowfl {
        return flowfl_foraging_fits_the_arena(c);
    }
    positive("world.foraging.nest_radius_m", f.nest_radius_m, 100.0)?;
    number(
        "world.foraging.nest_radius_m",
        f.nest_radius_m,
        0.0,
        c.world.arena_side_m / 2.0,
    )?;
    inside(c, "world.foraging.nest_x_m", f.nest_x_m, f.nest_radius_m)?;
    inside(c, "world.foraging.nest_y_m", f.nest_y_m, f.nest_radius_m)?;
    food_sources_are_counted(c)?;
    positive("world.foraging.food_radius_m", f.food_radius_m, 100.0)?;
    number(
        "world.foraging.food_radius_m",
        f.food_radius_m,
        0.0,
        c.world.arena_side_m / 4.0,
    )?;
    number("world.foraging.rest_s", f.rest_s, 0.0, 1.0e7)
}

/// The number of food sources, from `food_sources` or `food_per_robot x world.robots`.
fn food_sources_are_counted(c: &Config) -> Result<(), ConfigError> {
    let f = &c.world.foraging;
    let (key, value) = if f.food_per_robot > 0 {
        ("world.foraging.food_per_robot", f.food_per_robot)
    } else {
        ("world.foraging.food_sources", f.food_sources)
    };
    let count = f.food_count(c.world.robots);
    if (1..=10_000).contains(&count) {
        return Ok(());
    }
    out_of_range(
        key,
        value.to_string(),
        format!(
            "a food count in [1, 10000] (food_per_robot x world.robots = {} x {}, or \
             food_sources when food_per_robot = 0)",
            f.food_per_robot, c.world.robots
        ),
    )
}

/// Flow-FL's foraging arena (`world/foraging_flowfl.rs`) is laid out in metres from the
/// center: the nest strip west of x = -1 m, items in [-0.9, 1.7] x [-1.7, 1.7], lights on the
/// west wall; the arena must hold it with a robot's body to spare.
fn flowfl_foraging_fits_the_arena(c: &Config) -> Result<(), ConfigError> {
    let f = &c.world.foraging;
    food_sources_are_counted(c)?;
    positive("world.foraging.food_radius_m", f.food_radius_m, 1.0)?;
    // Its probabilities and times are per tick of ARGoS's 10 ticks a second.
    if (c.run.tick_s - 0.1).abs() > 1e-12 {
        return out_of_range(
            "run.tick_s",
            show_f64(c.run.tick_s),
            "0.1 with world.foraging.rule = \"flowfl\" (Flow-FL's probabilities are per tick \
             of 0.1 s); set run.tick_s=0.1 or use rule \"simple\""
                .to_string(),
        );
    }
    let need = 2.0 * (super::behaviour::FLOWFL_LAYOUT_HALF_M + c.world.robot_radius_m);
    if c.world.arena_side_m >= need {
        return Ok(());
    }
    out_of_range(
        "world.arena_side_m",
        show_f64(c.world.arena_side_m),
        format!(
            "at least {need} m with world.foraging.rule = \"flowfl\" (Flow-FL's foraging arena: \
             nest strip, items to +-1.7 m); enlarge the arena or use rule \"simple\""
        ),
    )
}

/// `world.home_range` (`world/home_range.rs`): `alpha` is `"inf"` or a positive number, `regions`
/// a positive perfect square, `goal_period_s` positive; with the knob on (a finite `alpha`),
/// only the avoidance behaviour (the paper's world) and regions whose side is at least
/// [`MIN_REGION_DIAMETERS`] robot diameters.
pub(super) fn home_range_fits(c: &Config) -> Result<(), ConfigError> {
    let w = &c.world;
    let h = &w.home_range;
    if h.alpha.is_nan() || h.alpha <= 0.0 {
        return out_of_range(
            "world.home_range.alpha",
            show_f64(h.alpha),
            "a positive number (e.g. --set world.home_range.alpha=0.1: few regions per robot) or \"inf\" (the default: no home range)".to_string(),
        );
    }
    integer("world.home_range.regions", h.regions.into(), 1, 10_000)?;
    if h.side().is_none() {
        let k = (f64::from(h.regions).sqrt().round() as u32).max(1);
        return out_of_range(
            "world.home_range.regions",
            h.regions.to_string(),
            format!(
                "a square grid: 1, 4, 9, 16, ... (e.g. --set world.home_range.regions={})",
                k * k
            ),
        );
    }
    positive("world.home_range.goal_period_s", h.goal_period_s, 1.0e6)?;
    if !h.is_on() {
        return Ok(());
    }
    if w.behaviour != Behaviour::Avoidance {
        return out_of_range(
            "world.home_range.alpha",
            show_f64(h.alpha),
            format!(
                "\"inf\" with world.behaviour = \"{}\": home ranges apply to the avoidance walk only; set world.behaviour=avoidance or world.home_range.alpha=inf",
                w.behaviour.name()
            ),
        );
    }
    let k = h.side().expect("checked above");
    let region = w.arena_side_m / f64::from(k);
    let smallest = MIN_REGION_DIAMETERS * 2.0 * w.robot_radius_m;
    if region < smallest {
        let most = (w.arena_side_m / smallest).floor().max(1.0) as u32;
        return out_of_range(
            "world.home_range.regions",
            h.regions.to_string(),
            format!(
                "at most {} in a {} m arena: a region's side ({} m) must be at least {} robot diameters ({} m); set world.home_range.regions={} or fewer",
                most * most,
                show_f64(w.arena_side_m),
                show_f64(region),
                show_f64(MIN_REGION_DIAMETERS),
                show_f64(smallest),
                most * most
            ),
        );
    }
    Ok(())
}

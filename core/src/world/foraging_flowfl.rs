//! Flow-FL's foraging (`world.foraging.rule = "flowfl"`, the `flowfl-foraging` preset;
//! docs/SPEC.md section 1, "The `flowfl` presets"): the controller and arena of NESTLab's
//! TrajectoryCollection (`argos-scripts/controllers/khepera_foraging/khepera_foraging.cpp`,
//! `loop_functions/foraging_loop_functions/foraging_loop_functions.cpp`,
//! `experiments/foraging_batch.argos`; ARGoS's Khepera IV light and ground sensors from
//! NESTLab/argos3-kheperaiv), re-implemented from their rules, not their code.
//!
//! The arena: the nest is the strip x < -1 m (a grey floor) lit by four lights at x = -2 m,
//! y = -1.5, -0.5, 0.5, 1.5 m, 1 m up, intensity 3. `world.foraging.food_count` items lie
//! uniformly in [-0.9, 1.7] x [-1.7, 1.7] m; a robot without an item whose center is east of
//! the nest and within `world.foraging.food_radius_m` of an item's center takes it (the first
//! in item order); the item leaves the floor until its carrier's center crosses into the nest,
//! when it is delivered and the item reappears at a new uniform spot. The robots start resting,
//! placed in the nest (`world/mod.rs`, `place_robots`).
//!
//! A forager, each tick, in Flow-FL's order (probabilities clamped to [0, 1]; every rule moves
//! them by 0.01):
//! - `Rest`: after more than 2 ticks of rest, leaves for `Explore` with probability
//!   `rest_to_explore`; else stays, stops announcing its last result after one tick, and for
//!   each robot in range-and-bearing contact that announced a result last tick moves its
//!   probabilities (social rule: a found item raises `rest_to_explore` and lowers
//!   `explore_to_rest`, a fruitless trip the reverse).
//! - `Explore`: with an item, the food rule (`explore_to_rest` down, `rest_to_explore` up) and
//!   `Return` with result "found"; after more than 6000 fruitless ticks, `Return` with
//!   probability `explore_to_rest` and result "not found", else the food rule the other way.
//!   Otherwise it moves along its diffusion vector (straight, or away from what its
//!   proximity sensors see), and away from the lights at a quarter weight while in the nest;
//!   every tick it sees something (collision rule) raises `explore_to_rest` and lowers
//!   `rest_to_explore`. So a forager that meets many walls and robots rests for long: at
//!   `rest_to_explore` 0 only its neighbours' finds wake it.
//! - `Return`: diffusion plus the light vector; once in the nest (both rear ground sensors on
//!   the grey), it drives on for 50 more ticks to find a place, then stops, announces its
//!   result and rests.
//!
//! The state changes in the reducer ([`FlowflForaging::advance`], after each tick's physics,
//! with each forager's own `Purpose::Foraging` stream and the items' stream kept in the state),
//! so replay reproduces it and the world's digest covers it. The controller side ([`command`])
//! turns the state's [`Drive`] into wheel speeds with Flow-FL's `SetWheelSpeedsFromVector`
//! (no, soft and hard turns with hysteresis). Where ours differs: sensors are read after the
//! physics of the tick instead of before the loop functions' pick-up (one tick apart), the
//! light is never occluded (Flow-FL's arena has no obstacles and its walls are lower than the
//! lights), and robots cannot push each other.

use serde::{Deserialize, Serialize};

use super::steering::WheelCommand;
use super::Pose;
use crate::config::{Avoidance, Config, FLOWFL_LAYOUT_HALF_M};
use crate::rng::{self, Purpose, Rng};
use crate::types::RobotId;

/// The nest's east edge: the floor is grey west of it (`GetFloorColor`).
pub const NEST_EDGE_X_M: f64 = -1.0;
/// The items' region (`m_cForagingArenaSideX`, `m_cForagingArenaSideY`).
const ITEMS_X_M: (f64, f64) = (-0.9, FLOWFL_LAYOUT_HALF_M);
const ITEMS_Y_M: (f64, f64) = (-FLOWFL_LAYOUT_HALF_M, FLOWFL_LAYOUT_HALF_M);
/// The lights of `foraging_batch.argos`: (x, y) in metres, all 1 m up, intensity 3.
const LIGHTS: [(f64, f64); 4] = [(-2.0, -1.5), (-2.0, -0.5), (-2.0, 0.5), (-2.0, 1.5)];
const LIGHT_HEIGHT_M: f64 = 1.0;
const LIGHT_INTENSITY: f64 = 3.0;
/// The Khepera IV's ground sensors 2 and 3 (robot frame, metres): the nest test reads these.
const REAR_GROUND: [(f64, f64); 2] = [(0.0206, -0.059), (0.0614, -0.01)];
/// `initial_rest_to_explore_prob`, `initial_explore_to_rest_prob`.
const INITIAL_PROBABILITY: f64 = 0.1;
/// Every `*_delta_prob` of `foraging_batch.argos`.
const DELTA: f64 = 0.01;
/// `minimum_resting_time`, `minimum_unsuccessful_explore_time`,
/// `minimum_search_for_place_in_nest_time`, in ticks of 0.1 s.
const MIN_REST_TICKS: u32 = 2;
const MIN_FRUITLESS_TICKS: u32 = 6000;
const MIN_SEARCH_TICKS: u32 = 50;
/// `go_straight_angle_range` (+-5 degrees) and `delta` of the diffusion.
const STRAIGHT_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
const DIFFUSION_DELTA: f64 = 0.1;
/// `hard_turn_angle_threshold`, `soft_turn_angle_threshold`, `no_turn_angle_threshold`.
const HARD_TURN_RAD: f64 = std::f64::consts::FRAC_PI_2;
const SOFT_TURN_RAD: f64 = 70.0 * std::f64::consts::PI / 180.0;
const NO_TURN_RAD: f64 = 10.0 * std::f64::consts::PI / 180.0;
/// Weight of the light in the nest while exploring (anti-phototaxis).
const AWAY_FROM_LIGHT: f64 = 0.25;
/// The Khepera IV light sensor: 8 sensors from the heading; its reading code spaces them by
/// pi / 12 when it picks the nearest one (ARGoS plugin `kheperaiv_light_rotzonly_sensor.cpp`,
/// `SENSOR_SPACING`), which we keep: some bearings light no sensor.
const LIGHT_SENSORS: u32 = 8;
const LIGHT_INDEX_SPACING_RAD: f64 = std::f64::consts::PI / 12.0;

/// Where a forager is in its cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Phase {
    /// Standing in the nest.
    Rest,
    /// Looking for an item.
    Explore,
    /// Going back to the nest (with an item or after a fruitless trip).
    Return,
}

/// The result a forager announces on range-and-bearing (`LAST_EXPLORATION_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Report {
    /// Nothing to tell.
    None,
    /// The last trip brought an item.
    Found,
    /// The last trip found nothing.
    NotFound,
}

/// What the controller does with the wheels this tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Drive {
    /// Keep the last command (Flow-FL sets no speed on a tick that changes state).
    Hold,
    /// Stop.
    Stop,
    /// The diffusion vector.
    Explore,
    /// The diffusion vector away from the lights (exploring in the nest).
    ExploreInNest,
    /// The diffusion vector plus the light vector.
    Return,
}

/// One forager's state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlowflForager {
    /// Where it is in its cycle.
    pub phase: Phase,
    /// Probability a tick of leaving the rest (after the minimum rest).
    pub rest_to_explore: f64,
    /// Probability a tick of giving up a fruitless search (after the minimum search).
    pub explore_to_rest: f64,
    rested_ticks: u32,
    fruitless_ticks: u32,
    searching_ticks: u32,
    /// The item carried, by index.
    pub item: Option<u32>,
    last: Report,
    /// What it announces now (read by its neighbours next tick).
    sent: Report,
    /// What the controller does this tick.
    pub drive: Drive,
    rng: Rng,
}

/// The foraging state of a swarm under Flow-FL's rule.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlowflForaging {
    /// One per robot (robots that do not forage keep their initial state).
    pub robots: Vec<FlowflForager>,
    /// Whether each robot forages.
    forages: Vec<bool>,
    /// The items on the floor, by index (`None` while carried).
    pub items: Vec<Option<(f64, f64)>>,
    item_rng: Rng,
    pickup_radius_m: f64,
    /// Items ever delivered.
    pub deliveries: u64,
    /// The proximity ring, for the diffusion vector.
    avoidance: Avoidance,
}

impl FlowflForaging {
    /// The state at time 0: every forager resting with its initial probabilities (and its
    /// minimum rest done, so it may leave at once, as Flow-FL's `Reset`), the items placed.
    pub fn new(config: &Config, seed: u64, forages: Vec<bool>) -> FlowflForaging {
        let f = &config.world.foraging;
        let mut item_rng = rng::stream(seed, Purpose::Foraging, u32::MAX);
        let items = (0..f.food_count(config.world.robots))
            .map(|_| Some(place_item(&mut item_rng)))
            .collect();
        let robots = (0..forages.len() as u32)
            .map(|i| FlowflForager {
                phase: Phase::Rest,
                rest_to_explore: INITIAL_PROBABILITY,
                explore_to_rest: INITIAL_PROBABILITY,
                rested_ticks: MIN_REST_TICKS,
                fruitless_ticks: 0,
                searching_ticks: 0,
                item: None,
                last: Report::None,
                sent: Report::None,
                drive: Drive::Hold,
                rng: rng::stream(seed, Purpose::Foraging, i),
            })
            .collect();
        FlowflForaging {
            robots,
            forages,
            items,
            item_rng,
            pickup_radius_m: f.food_radius_m,
            deliveries: 0,
            avoidance: config.world.avoidance,
        }
    }

    /// Moves every forager on after a tick's physics: the loop functions' pick-up and delivery,
    /// then each forager's step. `proximity` fills a robot's proximity readings, `contacts`
    /// the range-and-bearing contacts (called only when some robot announced a result).
    pub(super) fn advance(
        &mut self,
        poses: &[Pose],
        mut proximity: impl FnMut(usize, &mut [f64]),
        readings_len: usize,
        contacts: impl FnOnce(&mut Vec<Vec<RobotId>>),
    ) {
        assert_eq!(
            poses.len(),
            self.robots.len(),
            "one forager state per robot"
        );
        self.pick_and_deliver(poses);
        let sent: Vec<Report> = self.robots.iter().map(|r| r.sent).collect();
        let mut heard = Vec::new();
        if sent.iter().any(|&s| s != Report::None) {
            contacts(&mut heard);
        }
        let mut readings = vec![0.0; readings_len];
        for (i, r) in self.robots.iter_mut().enumerate() {
            if !self.forages[i] {
                continue;
            }
            match r.phase {
                Phase::Rest => rest(r, heard.get(i).map_or(&[], Vec::as_slice), &sent),
                Phase::Explore => {
                    proximity(i, &mut readings);
                    let collision = diffusion(self.avoidance, &readings).1;
                    explore(r, in_nest(poses[i]), collision);
                }
                Phase::Return => return_to_nest(r, in_nest(poses[i])),
            }
        }
    }

    /// `CForagingLoopFunctions::PreStep`: deliver in the nest, pick up outside it.
    fn pick_and_deliver(&mut self, poses: &[Pose]) {
        let r2 = self.pickup_radius_m * self.pickup_radius_m;
        for (i, p) in poses.iter().enumerate() {
            if !self.forages[i] {
                continue;
            }
            let robot = &mut self.robots[i];
            match robot.item {
                Some(k) if p.x < NEST_EDGE_X_M => {
                    self.items[k as usize] = Some(place_item(&mut self.item_rng));
                    robot.item = None;
                    self.deliveries += 1;
                }
                None if p.x > NEST_EDGE_X_M => {
                    let found = self.items.iter().position(|item| {
                        item.is_some_and(|(x, y)| {
                            (p.x - x) * (p.x - x) + (p.y - y) * (p.y - y) < r2
                        })
                    });
                    if let Some(k) = found {
                        self.items[k] = None;
                        robot.item = Some(k as u32);
                    }
                }
                _ => {}
            }
        }
    }
}

fn place_item(rng: &mut Rng) -> (f64, f64) {
    let x = rng.range(ITEMS_X_M.0, ITEMS_X_M.1);
    let y = rng.range(ITEMS_Y_M.0, ITEMS_Y_M.1);
    (x, y)
}

/// Moves `p` by `delta`, clamped to [0, 1] (`ProbRange.TruncValue`).
fn nudge(p: &mut f64, delta: f64) {
    *p = (*p + delta).clamp(0.0, 1.0);
}

/// `CKheperaForaging::Rest`.
fn rest(r: &mut FlowflForager, heard: &[RobotId], sent: &[Report]) {
    r.drive = Drive::Hold;
    if r.rested_ticks > MIN_REST_TICKS && r.rng.uniform() < r.rest_to_explore {
        r.phase = Phase::Explore;
        r.rested_ticks = 0;
        return;
    }
    r.rested_ticks += 1;
    if r.rested_ticks == 1 {
        r.sent = Report::None;
    }
    for &j in heard {
        match sent[j as usize] {
            Report::Found => {
                nudge(&mut r.rest_to_explore, DELTA);
                nudge(&mut r.explore_to_rest, -DELTA);
            }
            Report::NotFound => {
                nudge(&mut r.explore_to_rest, DELTA);
                nudge(&mut r.rest_to_explore, -DELTA);
            }
            Report::None => {}
        }
    }
}

/// `CKheperaForaging::Explore`.
fn explore(r: &mut FlowflForager, in_nest: bool, collision: bool) {
    let mut back = false;
    if r.item.is_some() {
        nudge(&mut r.explore_to_rest, -DELTA);
        nudge(&mut r.rest_to_explore, DELTA);
        r.last = Report::Found;
        back = true;
    } else if r.fruitless_ticks > MIN_FRUITLESS_TICKS {
        if r.rng.uniform() < r.explore_to_rest {
            r.last = Report::NotFound;
            back = true;
        } else {
            nudge(&mut r.explore_to_rest, DELTA);
            nudge(&mut r.rest_to_explore, -DELTA);
        }
    }
    if back {
        r.fruitless_ticks = 0;
        r.searching_ticks = 0;
        r.phase = Phase::Return;
        r.drive = Drive::Hold;
        return;
    }
    r.fruitless_ticks += 1;
    if collision {
        nudge(&mut r.explore_to_rest, DELTA);
        nudge(&mut r.rest_to_explore, -DELTA);
    }
    r.drive = if in_nest {
        Drive::ExploreInNest
    } else {
        Drive::Explore
    };
}

/// `CKheperaForaging::ReturnToNest`.
fn return_to_nest(r: &mut FlowflForager, in_nest: bool) {
    if in_nest {
        if r.searching_ticks > MIN_SEARCH_TICKS {
            r.drive = Drive::Stop;
            r.sent = r.last;
            r.phase = Phase::Rest;
            r.searching_ticks = 0;
            r.last = Report::None;
            return;
        }
        r.searching_ticks += 1;
    } else {
        r.searching_ticks = 0;
    }
    r.drive = Drive::Return;
}

/// Whether both rear ground sensors are on the nest's grey floor (`UpdateState`).
fn in_nest(p: Pose) -> bool {
    let (c, s) = (libm::cos(p.theta), libm::sin(p.theta));
    REAR_GROUND
        .iter()
        .all(|&(gx, gy)| p.x + c * gx - s * gy < NEST_EDGE_X_M)
}

/// `DiffusionVector`: the robot-frame unit vector to drive along and whether the proximity
/// sensors saw something (the collision rule). The readings' vector sum, if it points within
/// +-5 degrees of the heading and is shorter than 0.1, is ignored (straight on); else the robot
/// goes the opposite way.
fn diffusion(avoidance: Avoidance, readings: &[f64]) -> ((f64, f64), bool) {
    let n = readings.len() as u32;
    let (mut x, mut y) = (0.0, 0.0);
    for (k, &r) in readings.iter().enumerate() {
        let a = super::sensor_angle(avoidance, k as u32, n);
        x += r * libm::cos(a);
        y += r * libm::sin(a);
    }
    let angle = libm::atan2(y, x);
    let length = libm::hypot(x, y);
    if angle.abs() <= STRAIGHT_RAD && length < DIFFUSION_DELTA {
        ((1.0, 0.0), false)
    } else {
        ((-x / length, -y / length), true)
    }
}

/// `CalculateVectorToLight` on ARGoS's Khepera IV light sensor (`rot_z_only`): the robot-frame
/// unit vector along the sum of the sensors' readings, or zero if none reads. Each light adds
/// `exp(-2 d / intensity)` (d its 3-D distance, nothing beyond 2.5 x intensity), scaled by
/// `1 - 2 a / pi` (a the sensor's angular distance to the light's bearing, 0 past pi / 2), to
/// the five sensors around the index its code computes; each sensor is capped at 1.
fn light_vector(p: Pose) -> (f64, f64) {
    let mut values = [0.0f64; LIGHT_SENSORS as usize];
    for &(lx, ly) in &LIGHTS {
        let (dx, dy) = (lx - p.x, ly - p.y);
        let d = libm::sqrt(dx * dx + dy * dy + LIGHT_HEIGHT_M * LIGHT_HEIGHT_M) / LIGHT_INTENSITY;
        if d > 2.5 {
            continue;
        }
        let reading = libm::exp(-2.0 * d);
        let bearing = libm::atan2(dy, dx) - p.theta;
        let at = bearing / LIGHT_INDEX_SPACING_RAD;
        // C++'s conversion of `at + 0.5` (or `- 0.5`) to an integer truncates toward zero.
        let nearest = if at > 0.0 {
            (at + 0.5) as i64
        } else {
            (at - 0.5) as i64
        };
        for offset in -2..3i64 {
            let k = (nearest + offset).rem_euclid(i64::from(LIGHT_SENSORS));
            let sensor = 2.0 * std::f64::consts::PI * k as f64 / f64::from(LIGHT_SENSORS);
            let off = signed_normalize(bearing - sensor).abs();
            if off <= std::f64::consts::FRAC_PI_2 {
                values[k as usize] += reading * (1.0 - 2.0 * off / std::f64::consts::PI);
            }
        }
    }
    let (mut x, mut y) = (0.0, 0.0);
    for (k, v) in values.iter().enumerate() {
        let sensor = 2.0 * std::f64::consts::PI * k as f64 / f64::from(LIGHT_SENSORS);
        let v = v.clamp(0.0, 1.0);
        x += v * libm::cos(sensor);
        y += v * libm::sin(sensor);
    }
    let length = libm::hypot(x, y);
    if length > 0.0 {
        (x / length, y / length)
    } else {
        (0.0, 0.0)
    }
}

/// An angle in (-pi, pi].
fn signed_normalize(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut a = a % two_pi;
    if a > std::f64::consts::PI {
        a -= two_pi;
    } else if a <= -std::f64::consts::PI {
        a += two_pi;
    }
    a
}

/// The turning state of `SetWheelSpeedsFromVector` (driver side, one per robot).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) enum Turning {
    /// Both wheels at the base speed.
    #[default]
    None,
    /// One wheel slower, in proportion to the heading error.
    Soft,
    /// In place at full speed.
    Hard,
}

/// A Flow-FL forager's driver-side state: its turning state and its last command.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Wheels {
    turning: Turning,
    last: Option<WheelCommand>,
}

/// The wheel command of a forager in `drive`, at `pose`, with its proximity `readings`;
/// `max_mps` is Flow-FL's `max_speed` (`world.cruise_speed_mps`).
pub(super) fn command(
    wheels: &mut Wheels,
    drive: Drive,
    pose: Pose,
    avoidance: Avoidance,
    readings: &[f64],
    max_mps: f64,
) -> WheelCommand {
    let stop = WheelCommand::from_mps(0.0, 0.0);
    let to = match drive {
        Drive::Hold => return *wheels.last.get_or_insert(stop),
        Drive::Stop => {
            wheels.last = Some(stop);
            return stop;
        }
        Drive::Explore | Drive::ExploreInNest | Drive::Return => {
            let (d, _) = diffusion(avoidance, readings);
            let light = match drive {
                Drive::ExploreInNest => {
                    let (lx, ly) = light_vector(pose);
                    (-AWAY_FROM_LIGHT * lx, -AWAY_FROM_LIGHT * ly)
                }
                Drive::Return => light_vector(pose),
                _ => (0.0, 0.0),
            };
            (max_mps * (d.0 + light.0), max_mps * (d.1 + light.1))
        }
    };
    let command = wheel_speeds(&mut wheels.turning, to, max_mps);
    wheels.last = Some(command);
    command
}

/// `SetWheelSpeedsFromVector`: the robot-frame vector `to` (m/s) as wheel speeds.
fn wheel_speeds(turning: &mut Turning, to: (f64, f64), max_mps: f64) -> WheelCommand {
    let angle = libm::atan2(to.1, to.0);
    let base = libm::hypot(to.0, to.1).min(max_mps);
    let off = angle.abs();
    *turning = match *turning {
        Turning::Hard if off <= SOFT_TURN_RAD => Turning::Soft,
        t => t,
    };
    *turning = match *turning {
        Turning::Soft if off > HARD_TURN_RAD => Turning::Hard,
        Turning::Soft if off <= NO_TURN_RAD => Turning::None,
        t => t,
    };
    *turning = match *turning {
        Turning::None if off > HARD_TURN_RAD => Turning::Hard,
        Turning::None if off > NO_TURN_RAD => Turning::Soft,
        t => t,
    };
    let (slow, fast) = match *turning {
        Turning::None => (base, base),
        Turning::Soft => {
            let factor = (HARD_TURN_RAD - off) / HARD_TURN_RAD;
            (base - base * (1.0 - factor), base + base * (1.0 - factor))
        }
        Turning::Hard => (-max_mps, max_mps),
    };
    if angle > 0.0 {
        WheelCommand::from_mps(slow, fast)
    } else {
        WheelCommand::from_mps(fast, slow)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn forager() -> FlowflForager {
        FlowflForager {
            phase: Phase::Rest,
            rest_to_explore: INITIAL_PROBABILITY,
            explore_to_rest: INITIAL_PROBABILITY,
            rested_ticks: 0,
            fruitless_ticks: 0,
            searching_ticks: 0,
            item: None,
            last: Report::None,
            sent: Report::None,
            drive: Drive::Hold,
            rng: rng::stream(1, Purpose::Foraging, 0),
        }
    }

    #[test]
    fn every_tick_that_sees_something_makes_resting_likelier() {
        let mut r = forager();
        r.phase = Phase::Explore;
        for _ in 0..5 {
            explore(&mut r, false, true);
        }
        assert_eq!(r.phase, Phase::Explore);
        assert!(
            (r.explore_to_rest - 0.15).abs() < 1e-12,
            "{}",
            r.explore_to_rest
        );
        assert!(
            (r.rest_to_explore - 0.05).abs() < 1e-12,
            "{}",
            r.rest_to_explore
        );
        for _ in 0..10 {
            explore(&mut r, false, true);
        }
        assert_eq!(r.rest_to_explore, 0.0, "clamped at 0");
    }

    #[test]
    fn an_item_sends_the_forager_home_and_it_announces_the_find_for_one_tick() {
        let mut r = forager();
        r.phase = Phase::Explore;
        r.item = Some(3);
        explore(&mut r, false, false);
        assert_eq!((r.phase, r.drive), (Phase::Return, Drive::Hold));
        r.item = None;
        for _ in 0..=MIN_SEARCH_TICKS {
            return_to_nest(&mut r, true);
            assert_eq!(r.phase, Phase::Return);
        }
        return_to_nest(&mut r, true);
        assert_eq!(
            (r.phase, r.drive, r.sent),
            (Phase::Rest, Drive::Stop, Report::Found)
        );
        rest(&mut r, &[], &[]);
        assert_eq!(r.sent, Report::None, "announced for one tick");
    }

    #[test]
    fn a_neighbours_find_wakes_a_resting_forager() {
        let mut r = forager();
        r.rest_to_explore = 0.0;
        r.rested_ticks = 1;
        rest(
            &mut r,
            &[1, 2],
            &[Report::None, Report::Found, Report::Found],
        );
        assert!((r.rest_to_explore - 0.02).abs() < 1e-12);
        assert!((r.explore_to_rest - 0.08).abs() < 1e-12);
    }

    #[test]
    fn the_nest_is_the_strip_west_of_minus_one_metre_under_both_rear_sensors() {
        assert!(in_nest(Pose {
            x: -1.1,
            y: 0.0,
            theta: 0.0
        }));
        // Facing east at -1.05 m, the sensor 6 cm ahead is out of the nest.
        assert!(!in_nest(Pose {
            x: -1.05,
            y: 0.0,
            theta: 0.0
        }));
        assert!(in_nest(Pose {
            x: -1.05,
            y: 0.0,
            theta: std::f64::consts::PI
        }));
    }

    #[test]
    fn a_light_straight_ahead_pulls_straight_and_one_at_ninety_degrees_is_not_seen() {
        // Facing west from the center, the lights lie ahead: the vector points ahead.
        let (x, y) = light_vector(Pose {
            x: 0.0,
            y: 0.0,
            theta: std::f64::consts::PI,
        });
        assert!(x > 0.99 && y.abs() < 0.1, "({x}, {y})");
        // Facing north at the west wall between lights 2 and 3, they lie at about +-90 degrees:
        // Flow-FL's sensor index (spacing pi / 12) lights none of the sensors near them.
        let (x, y) = light_vector(Pose {
            x: -1.9,
            y: 0.0,
            theta: std::f64::consts::FRAC_PI_2,
        });
        assert!(x.abs() < 0.5, "({x}, {y})");
    }

    #[test]
    fn the_wheels_turn_hard_then_soft_then_go_straight() {
        let mut t = Turning::None;
        let c = wheel_speeds(&mut t, (-0.1, 0.01), 0.1);
        assert_eq!((t, c), (Turning::Hard, WheelCommand::from_mps(-0.1, 0.1)));
        let c = wheel_speeds(&mut t, (0.1, 0.05), 0.1);
        assert_eq!(t, Turning::Soft);
        assert!(c.right_mmps > c.left_mmps, "{c:?}");
        wheel_speeds(&mut t, (0.1, 0.001), 0.1);
        assert_eq!(t, Turning::None);
    }

    #[test]
    fn no_reading_goes_straight_without_collision() {
        assert_eq!(
            diffusion(Avoidance::Khepera, &[0.0; 8]),
            ((1.0, 0.0), false)
        );
        let mut front = [0.0; 8];
        front[0] = 0.5;
        let ((x, _), hit) = diffusion(Avoidance::Khepera, &front);
        assert!(hit && x < -0.99);
    }
}

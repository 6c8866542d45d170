//! Differential-drive kinematics and collision-free motion.
//!
//! Robots move one after the other in robot order within a tick, each against the current
//! positions of the others (earlier robots already moved). A robot always takes its rotation
//! (a disk turning in place cannot overlap anything); its translation is taken only if every
//! point of the straight path, checked in sub-steps of at most half a radius, is free of walls,
//! obstacles and robots. Otherwise the robot *stays* where it is (it does not slide): the
//! controller sees the obstacle on its proximity sensors and turns away. Touching is allowed,
//! overlapping never.
//!
//! With `world.slide_on_contact` (ARGoS's dynamics2d, where a robot pushing against a wall,
//! an obstacle or another robot slides along it), a refused translation is replaced by its
//! part tangent to the nearest contact at the robot's place (the nearest wall, obstacle or
//! robot within the move's length: the move minus its component into that contact's normal),
//! taken if its path is free in the same sub-steps. Without it, a
//! robot driving slightly into something its sensors do not weigh (a robot beside it) stays
//! there for good.

use serde::{Deserialize, Serialize};

use super::arena::{Arena, GridShape, Obstacle};
use super::steering::WheelCommand;
use super::Pose;

/// Most sub-steps of one move; a longer move (over 2048 radii in a tick) is refused.
const MAX_SUBSTEPS: u32 = 4096;

/// The robot body and the tick.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Body {
    /// Radius of the disk in metres.
    pub radius_m: f64,
    /// Distance between the wheels in metres.
    pub wheel_base_m: f64,
    /// Length of the tick in seconds.
    pub dt_s: f64,
}

/// Robots indexed by the grid cell of their center; kept exact as robots move.
#[derive(Clone, Debug, Default)]
pub struct RobotGrid {
    cells: Vec<Vec<u32>>,
    cell_of: Vec<u32>,
}

impl RobotGrid {
    /// Re-indexes every robot.
    pub fn rebuild(&mut self, shape: &GridShape, poses: &[Pose]) {
        self.cells.resize(shape.cell_count(), Vec::new());
        for c in &mut self.cells {
            c.clear();
        }
        self.cell_of.clear();
        for (i, p) in poses.iter().enumerate() {
            let c = shape.cell_of(p.x, p.y);
            self.cells[c as usize].push(i as u32);
            self.cell_of.push(c);
        }
    }

    /// Adds robot `i` (the next index) at (`x`, `y`).
    pub fn push(&mut self, shape: &GridShape, x: f64, y: f64) {
        self.cells.resize(shape.cell_count(), Vec::new());
        let c = shape.cell_of(x, y);
        self.cells[c as usize].push(self.cell_of.len() as u32);
        self.cell_of.push(c);
    }

    /// Moves robot `i` to (`x`, `y`).
    pub fn relocate(&mut self, shape: &GridShape, i: u32, x: f64, y: f64) {
        let c = shape.cell_of(x, y);
        let old = self.cell_of[i as usize];
        if c != old {
            let cell = &mut self.cells[old as usize];
            let at = cell
                .iter()
                .position(|&r| r == i)
                .expect("robot indexed in its cell");
            cell.swap_remove(at);
            self.cells[c as usize].push(i);
            self.cell_of[i as usize] = c;
        }
    }

    /// Calls `f` for every robot whose center lies in a cell overlapping the box.
    pub fn near(
        &self,
        shape: &GridShape,
        x0: f64,
        y0: f64,
        x1: f64,
        y1: f64,
        mut f: impl FnMut(u32),
    ) {
        shape.for_cells(x0, y0, x1, y1, |c| {
            for &r in &self.cells[c as usize] {
                f(r);
            }
        });
    }

    /// Number of robots indexed.
    pub fn robots(&self) -> usize {
        self.cell_of.len()
    }
}

/// Whether a robot disk of radius `r` at (`x`, `y`) would overlap a wall, an obstacle or a
/// robot other than `skip`.
pub fn blocked(
    arena: &Arena,
    grid: &RobotGrid,
    poses: &[Pose],
    r: f64,
    skip: u32,
    x: f64,
    y: f64,
) -> bool {
    if arena.disk_blocked(x, y, r) {
        return true;
    }
    let d = 2.0 * r;
    let mut hit = false;
    grid.near(&arena.grid, x - d, y - d, x + d, y + d, |j| {
        if j != skip && !hit {
            let q = &poses[j as usize];
            hit = (q.x - x) * (q.x - x) + (q.y - y) * (q.y - y) < d * d;
        }
    });
    hit
}

/// The unit normal, pointing away from it, of the nearest wall, obstacle or robot (other than
/// `skip`) that a disk of radius `r` at (`x`, `y`) moving by `m` comes less than the move's
/// length near and moves toward (the deepest, if it overlaps some); `None` if there is none.
/// Ties go to the first found (walls, then obstacles, then robots, in index order).
#[allow(clippy::too_many_arguments)]
fn contact_normal(
    arena: &Arena,
    grid: &RobotGrid,
    poses: &[Pose],
    r: f64,
    skip: u32,
    x: f64,
    y: f64,
    m: (f64, f64),
) -> Option<(f64, f64)> {
    let margin = (m.0 * m.0 + m.1 * m.1).sqrt();
    let mut best: Option<(f64, (f64, f64))> = None;
    let mut consider = |depth: f64, n: (f64, f64)| {
        if depth > -margin && m.0 * n.0 + m.1 * n.1 < 0.0 && best.is_none_or(|(d, _)| depth > d) {
            best = Some((depth, n));
        }
    };
    let h = arena.half_side_m;
    consider(x + r - h, (-1.0, 0.0));
    consider(r - h - x, (1.0, 0.0));
    consider(y + r - h, (0.0, -1.0));
    consider(r - h - y, (0.0, 1.0));
    // Away from the nearest point of a body at `distance` (its closest point is `q`).
    let away = |qx: f64, qy: f64, distance: f64| ((x - qx) / distance, (y - qy) / distance);
    let (ro, reach) = (r + margin, 2.0 * r + margin);
    arena.obstacles_near(x - ro, y - ro, x + ro, y + ro, |o| {
        let (qx, qy) = match arena.obstacles[o as usize] {
            Obstacle::Cylinder {
                x: cx,
                y: cy,
                radius_m,
            } => {
                let d = ((x - cx) * (x - cx) + (y - cy) * (y - cy)).sqrt();
                if d > 0.0 {
                    consider(radius_m + r - d, away(cx, cy, d));
                }
                return;
            }
            Obstacle::Box {
                x: bx,
                y: by,
                half_side_m,
            } => (
                x.clamp(bx - half_side_m, bx + half_side_m),
                y.clamp(by - half_side_m, by + half_side_m),
            ),
        };
        let d = ((x - qx) * (x - qx) + (y - qy) * (y - qy)).sqrt();
        if d > 0.0 {
            consider(r - d, away(qx, qy, d));
        }
    });
    grid.near(
        &arena.grid,
        x - reach,
        y - reach,
        x + reach,
        y + reach,
        |j| {
            if j != skip {
                let q = &poses[j as usize];
                let d = ((q.x - x) * (q.x - x) + (q.y - y) * (q.y - y)).sqrt();
                if d > 0.0 {
                    consider(2.0 * r - d, away(q.x, q.y, d));
                }
            }
        },
    );
    best.map(|(_, n)| n)
}

/// Whether robot `i`, at `p`, can translate by (`dx`, `dy`): every sub-step of at most half a
/// radius is free.
#[allow(clippy::too_many_arguments)]
fn path_free(
    arena: &Arena,
    grid: &RobotGrid,
    poses: &[Pose],
    r: f64,
    i: u32,
    p: Pose,
    dx: f64,
    dy: f64,
) -> bool {
    let len = (dx * dx + dy * dy).sqrt();
    let substeps = (len / (0.5 * r)).ceil();
    substeps <= f64::from(MAX_SUBSTEPS) && {
        let n = substeps.max(1.0) as u32;
        (1..=n).all(|k| {
            let f = f64::from(k) / f64::from(n);
            let (x, y) = if k == n {
                (p.x + dx, p.y + dy)
            } else {
                (p.x + f * dx, p.y + f * dy)
            };
            !blocked(arena, grid, poses, r, i, x, y)
        })
    }
}

/// What one robot does in one tick: its new heading, and where it translates to (`None`: it
/// does not translate, `Some(None)`: its translation is refused).
#[derive(Clone, Copy, Debug)]
struct Outcome {
    theta: f64,
    translation: Option<Option<(f64, f64)>>,
}

/// Robot `i`'s move for `command` against the current `poses` (indexed by `grid`); reads only
/// robots whose centers lie within `2 r + |len|` of the robot's (the checked path and the
/// contacts a slide considers).
#[allow(clippy::too_many_arguments)]
fn outcome(
    arena: &Arena,
    grid: &RobotGrid,
    poses: &[Pose],
    body: &Body,
    command: &WheelCommand,
    slide: bool,
    i: usize,
) -> Outcome {
    let r = body.radius_m;
    let (left, right) = (command.left_mps(), command.right_mps());
    let v = 0.5 * (left + right);
    let w = (right - left) / body.wheel_base_m;
    let p = poses[i];
    // Midpoint heading: exact for straight moves and turns in place.
    let mid = p.theta + 0.5 * w * body.dt_s;
    let theta = wrap_angle(p.theta + w * body.dt_s);
    let len = v * body.dt_s;
    if len == 0.0 {
        return Outcome {
            theta,
            translation: None,
        };
    }
    let (s, c) = libm::sincos(mid);
    let (dx, dy) = (len * c, len * s);
    let substeps = (len.abs() / (0.5 * r)).ceil();
    let free = substeps <= f64::from(MAX_SUBSTEPS) && {
        let n = substeps.max(1.0) as u32;
        (1..=n).all(|k| {
            let f = f64::from(k) / f64::from(n);
            let (x, y) = if k == n {
                (p.x + dx, p.y + dy)
            } else {
                (p.x + f * dx, p.y + f * dy)
            };
            !blocked(arena, grid, poses, r, i as u32, x, y)
        })
    };
    let taken = if free {
        Some((dx, dy))
    } else if slide {
        contact_normal(arena, grid, poses, r, i as u32, p.x, p.y, (dx, dy))
            .map(|(nx, ny)| {
                let into = dx * nx + dy * ny;
                (dx - into * nx, dy - into * ny)
            })
            .filter(|&(sx, sy)| {
                (sx != 0.0 || sy != 0.0) && path_free(arena, grid, poses, r, i as u32, p, sx, sy)
            })
    } else {
        None
    };
    Outcome {
        theta,
        translation: Some(taken.map(|(tx, ty)| (p.x + tx, p.y + ty))),
    }
}

/// The length of robot `i`'s translation this tick (as [`outcome`] computes it).
fn move_length(body: &Body, command: &WheelCommand) -> f64 {
    0.5 * (command.left_mps() + command.right_mps()) * body.dt_s
}

/// Takes robot `i`'s outcome into `poses` and `grid`; 1 if its translation was refused.
fn take(arena: &Arena, grid: &mut RobotGrid, poses: &mut [Pose], i: usize, o: Outcome) -> u64 {
    poses[i].theta = o.theta;
    match o.translation {
        None => 0,
        Some(None) => 1,
        Some(Some((x, y))) => {
            poses[i].x = x;
            poses[i].y = y;
            grid.relocate(&arena.grid, i as u32, x, y);
            0
        }
    }
}

/// Moves every robot by its wheel command for one tick; returns how many translations were
/// refused (a slid one counts as taken). `grid` must index `poses` on entry and indexes them
/// on exit. `slide`: `world.slide_on_contact`.
pub fn step(
    arena: &Arena,
    grid: &mut RobotGrid,
    poses: &mut [Pose],
    body: &Body,
    commands: &[WheelCommand],
    slide: bool,
) -> u64 {
    assert_eq!(commands.len(), poses.len(), "one wheel command per robot");
    debug_assert_eq!(grid.robots(), poses.len());
    let mut refused = 0;
    for (i, command) in commands.iter().enumerate() {
        let o = outcome(arena, grid, poses, body, command, slide, i);
        refused += take(arena, grid, poses, i, o);
    }
    refused
}

/// Added to the reach within which two robots may meet in a tick, against rounding.
const REACH_SLACK_M: f64 = 1e-6;

/// [`step`] on `pool`'s threads, with the same result to the bit.
///
/// In [`step`], robot `i` reads the robots before it at their new places and those after it
/// at their old ones, but only robots within `2 r + |len_i|` of it (its path's checks and a
/// slide's contacts), and a robot moves at most `L = max |len|` in a tick. A robot with no
/// other robot's old center within `2 r + 2 L` of its own therefore reads no robot, whatever
/// order the others move in: its outcome is computed in parallel against the old state. The
/// other robots (at the paper's density, about 2 %) are computed afterwards in robot order,
/// between the outcomes taken in robot order, so each reads exactly the state [`step`] shows
/// it, and the grid sees the same relocations in the same order.
///
/// `nearest`, if given, holds each robot's squared distance to the nearest other robot of
/// `poses` among all within the distance that comes with it (infinite if none): when the
/// reach is within that distance, a robot is alone exactly when its nearest is at least the
/// reach away, and the grid is not searched again.
#[allow(clippy::too_many_arguments)]
pub fn step_parallel(
    pool: &rayon::ThreadPool,
    arena: &Arena,
    grid: &mut RobotGrid,
    poses: &mut [Pose],
    body: &Body,
    commands: &[WheelCommand],
    slide: bool,
    nearest: Option<(&[f64], f64)>,
) -> u64 {
    use rayon::prelude::*;
    assert_eq!(commands.len(), poses.len(), "one wheel command per robot");
    debug_assert_eq!(grid.robots(), poses.len());
    let longest = commands
        .iter()
        .map(|c| move_length(body, c).abs())
        .fold(0.0, f64::max);
    let reach = 2.0 * body.radius_m + 2.0 * longest + REACH_SLACK_M;
    let nearest = nearest
        .filter(|&(d2, within)| d2.len() == poses.len() && reach <= within)
        .map(|(d2, _)| d2);
    let (shared_grid, shared_poses) = (&*grid, &*poses);
    let alone: Vec<Option<Outcome>> = pool.install(|| {
        (0..shared_poses.len())
            .into_par_iter()
            .with_min_len(super::par::PIECE)
            .map(|i| {
                let p = shared_poses[i];
                let mut alone = true;
                if let Some(d2) = nearest {
                    alone = d2[i] >= reach * reach;
                } else {
                    shared_grid.near(
                        &arena.grid,
                        p.x - reach,
                        p.y - reach,
                        p.x + reach,
                        p.y + reach,
                        |j| {
                            if alone && j as usize != i {
                                let q = &shared_poses[j as usize];
                                alone = (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y)
                                    >= reach * reach;
                            }
                        },
                    );
                }
                alone.then(|| {
                    outcome(
                        arena,
                        shared_grid,
                        shared_poses,
                        body,
                        &commands[i],
                        slide,
                        i,
                    )
                })
            })
            .collect()
    });
    let mut refused = 0;
    for (i, early) in alone.into_iter().enumerate() {
        let o = early.unwrap_or_else(|| outcome(arena, grid, poses, body, &commands[i], slide, i));
        refused += take(arena, grid, poses, i, o);
    }
    refused
}

/// Counts overlaps (robot-wall, robot-obstacle, robot-robot pairs); must be 0.
pub fn overlaps(arena: &Arena, grid: &RobotGrid, poses: &[Pose], r: f64) -> u64 {
    (0..poses.len())
        .map(|i| overlaps_of(arena, grid, poses, r, i))
        .sum()
}

/// [`overlaps`] on `pool`'s threads (a sum of integers: the same count).
pub fn overlaps_parallel(
    pool: &rayon::ThreadPool,
    arena: &Arena,
    grid: &RobotGrid,
    poses: &[Pose],
    r: f64,
) -> u64 {
    use rayon::prelude::*;
    pool.install(|| {
        (0..poses.len())
            .into_par_iter()
            .with_min_len(super::par::PIECE)
            .map(|i| overlaps_of(arena, grid, poses, r, i))
            .sum()
    })
}

/// Robot `i`'s overlaps: with a wall or an obstacle, and with robots after it.
fn overlaps_of(arena: &Arena, grid: &RobotGrid, poses: &[Pose], r: f64, i: usize) -> u64 {
    let mut count = u64::from(arena.disk_blocked(poses[i].x, poses[i].y, r));
    let d = 2.0 * r;
    let p = poses[i];
    grid.near(&arena.grid, p.x - d, p.y - d, p.x + d, p.y + d, |j| {
        let q = &poses[j as usize];
        if j as usize > i && (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y) < d * d {
            count += 1;
        }
    });
    count
}

/// The angle in [-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    if (-std::f64::consts::PI..=std::f64::consts::PI).contains(&a) {
        a
    } else {
        libm::remainder(a, 2.0 * std::f64::consts::PI)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Robot 0 drives at 10 degrees into robot 1, which touches it on its left: it can only
    /// move by sliding.
    fn side_by_side() -> (Arena, RobotGrid, Vec<Pose>, Body, Vec<WheelCommand>) {
        let arena = Arena::with_obstacles(2.0, Vec::new(), 0.5);
        let r = 0.035;
        let poses = vec![
            Pose {
                x: 0.0,
                y: 0.0,
                theta: 10f64.to_radians(),
            },
            Pose {
                x: 0.0,
                y: 2.0 * r,
                theta: 0.0,
            },
        ];
        let mut grid = RobotGrid::default();
        grid.rebuild(&arena.grid, &poses);
        let body = Body {
            radius_m: r,
            wheel_base_m: 0.053,
            dt_s: 0.1,
        };
        let commands = vec![
            WheelCommand::from_mps(0.025, 0.025),
            WheelCommand::from_mps(0.0, 0.0),
        ];
        (arena, grid, poses, body, commands)
    }

    #[test]
    fn a_robot_driving_into_its_neighbour_stays_unless_it_slides() {
        let (arena, mut grid, mut poses, body, commands) = side_by_side();
        assert_eq!(
            step(&arena, &mut grid, &mut poses, &body, &commands, false),
            1
        );
        assert_eq!((poses[0].x, poses[0].y), (0.0, 0.0));

        let (arena, mut grid, mut poses, body, commands) = side_by_side();
        assert_eq!(
            step(&arena, &mut grid, &mut poses, &body, &commands, true),
            0
        );
        // It moved forward along the neighbour (the tangent is +x), not into it.
        assert!(poses[0].x > 0.002, "{:?}", poses[0]);
        assert!(poses[0].y.abs() < 1e-9, "{:?}", poses[0]);
        assert_eq!(overlaps(&arena, &grid, &poses, body.radius_m), 0);
    }

    #[test]
    fn a_robot_slides_along_a_wall_and_stops_in_a_corner() {
        let arena = Arena::with_obstacles(1.0, Vec::new(), 0.5);
        let r = 0.035;
        let body = Body {
            radius_m: r,
            wheel_base_m: 0.053,
            dt_s: 0.1,
        };
        // Touching the top wall, heading 30 degrees into it.
        let mut poses = vec![Pose {
            x: 0.0,
            y: 1.0 - r,
            theta: 60f64.to_radians(),
        }];
        let mut grid = RobotGrid::default();
        grid.rebuild(&arena.grid, &poses);
        let go = vec![WheelCommand::from_mps(0.025, 0.025)];
        assert_eq!(step(&arena, &mut grid, &mut poses, &body, &go, true), 0);
        assert!(poses[0].x > 0.0 && poses[0].y == 1.0 - r, "{:?}", poses[0]);
        // Pushed into the corner, it can go nowhere.
        poses[0] = Pose {
            x: 1.0 - r,
            y: 1.0 - r,
            theta: 45f64.to_radians(),
        };
        grid.rebuild(&arena.grid, &poses);
        assert_eq!(step(&arena, &mut grid, &mut poses, &body, &go, true), 1);
    }
}

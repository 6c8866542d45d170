//! Differential-drive kinematics and collision-free motion.
//!
//! Robots move one after the other in robot order within a tick, each against the current
//! positions of the others (earlier robots already moved). A robot always takes its rotation
//! (a disk turning in place cannot overlap anything); its translation is taken only if every
//! point of the straight path, checked in sub-steps of at most half a radius, is free of walls,
//! obstacles and robots. Otherwise the robot *stays* where it is (it does not slide): the
//! controller sees the obstacle on its proximity sensors and turns away. Touching is allowed,
//! overlapping never.

use serde::{Deserialize, Serialize};

use super::arena::{Arena, GridShape};
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

/// Moves every robot by its wheel command for one tick; returns how many translations were
/// refused. `grid` must index `poses` on entry and indexes them on exit.
pub fn step(
    arena: &Arena,
    grid: &mut RobotGrid,
    poses: &mut [Pose],
    body: &Body,
    commands: &[WheelCommand],
) -> u64 {
    assert_eq!(commands.len(), poses.len(), "one wheel command per robot");
    debug_assert_eq!(grid.robots(), poses.len());
    let r = body.radius_m;
    let mut refused = 0;
    for i in 0..poses.len() {
        let (left, right) = (commands[i].left_mps(), commands[i].right_mps());
        let v = 0.5 * (left + right);
        let w = (right - left) / body.wheel_base_m;
        let p = poses[i];
        // Midpoint heading: exact for straight moves and turns in place.
        let mid = p.theta + 0.5 * w * body.dt_s;
        let theta = wrap_angle(p.theta + w * body.dt_s);
        poses[i].theta = theta;
        let len = v * body.dt_s;
        if len == 0.0 {
            continue;
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
        if free {
            poses[i].x = p.x + dx;
            poses[i].y = p.y + dy;
            grid.relocate(&arena.grid, i as u32, poses[i].x, poses[i].y);
        } else {
            refused += 1;
        }
    }
    refused
}

/// Counts overlaps (robot-wall, robot-obstacle, robot-robot pairs); must be 0.
pub fn overlaps(arena: &Arena, grid: &RobotGrid, poses: &[Pose], r: f64) -> u64 {
    let mut count = 0;
    let d = 2.0 * r;
    for (i, p) in poses.iter().enumerate() {
        if arena.disk_blocked(p.x, p.y, r) {
            count += 1;
        }
        grid.near(&arena.grid, p.x - d, p.y - d, p.x + d, p.y + d, |j| {
            let q = &poses[j as usize];
            if j as usize > i && (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y) < d * d {
                count += 1;
            }
        });
    }
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

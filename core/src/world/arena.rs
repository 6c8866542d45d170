//! The arena: square walls centered on the origin, static obstacles, and a uniform grid that
//! finds what is near a point without scanning everything.
//!
//! Geometry conventions: a robot is a disk; it *overlaps* something when the distance between
//! the shapes is strictly negative (touching is allowed). Obstacles are cylinders (disks in the
//! plane) or axis-aligned boxes with a square base.

use parry2d_f64::na::{Point2, Vector2};
use parry2d_f64::query::{Ray, RayCast};
use parry2d_f64::shape::{Ball, Cuboid};
use serde::{Deserialize, Serialize};

use super::WorldError;
use crate::config::WorldConfig;
use crate::rng::Rng;

/// Attempts per obstacle or robot before placement is declared impossible.
pub const PLACEMENT_ATTEMPTS: u32 = 10_000;

/// Up to this many obstacles, queries test them all rather than walk the grid.
const FEW_OBSTACLES: usize = 16;

/// Most grid cells per axis (bounds memory for huge arenas with short ranges).
const MAX_CELLS_PER_AXIS: u32 = 256;

/// A static obstacle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Obstacle {
    /// A cylinder: a disk of radius `radius_m` centered at (`x`, `y`).
    Cylinder {
        /// Center x in metres.
        x: f64,
        /// Center y in metres.
        y: f64,
        /// Radius in metres.
        radius_m: f64,
    },
    /// An axis-aligned box with a square base of half side `half_side_m` centered at (`x`, `y`).
    Box {
        /// Center x in metres.
        x: f64,
        /// Center y in metres.
        y: f64,
        /// Half of the side in metres.
        half_side_m: f64,
    },
}

impl Obstacle {
    /// The center.
    pub fn center(&self) -> (f64, f64) {
        match *self {
            Obstacle::Cylinder { x, y, .. } | Obstacle::Box { x, y, .. } => (x, y),
        }
    }

    /// Half the side of the obstacle's axis-aligned bounding box.
    pub fn extent_m(&self) -> f64 {
        match *self {
            Obstacle::Cylinder { radius_m, .. } => radius_m,
            Obstacle::Box { half_side_m, .. } => half_side_m,
        }
    }

    /// Squared distance from (`px`, `py`) to the obstacle (0 inside).
    pub fn distance_sq(&self, px: f64, py: f64) -> f64 {
        match *self {
            Obstacle::Cylinder { x, y, radius_m } => {
                let d = ((px - x) * (px - x) + (py - y) * (py - y)).sqrt() - radius_m;
                if d > 0.0 {
                    d * d
                } else {
                    0.0
                }
            }
            Obstacle::Box { x, y, half_side_m } => {
                let dx = ((px - x).abs() - half_side_m).max(0.0);
                let dy = ((py - y).abs() - half_side_m).max(0.0);
                dx * dx + dy * dy
            }
        }
    }

    /// Whether a disk of radius `r` at (`px`, `py`) overlaps the obstacle (touching does not).
    pub fn overlaps_disk(&self, px: f64, py: f64, r: f64) -> bool {
        match *self {
            Obstacle::Cylinder { x, y, radius_m } => {
                let s = radius_m + r;
                (px - x) * (px - x) + (py - y) * (py - y) < s * s
            }
            Obstacle::Box { .. } => self.distance_sq(px, py) < r * r,
        }
    }

    /// Whether two obstacles overlap (touching does not).
    pub fn overlaps(&self, other: &Obstacle) -> bool {
        match (*self, *other) {
            (Obstacle::Cylinder { x, y, radius_m }, o)
            | (o, Obstacle::Cylinder { x, y, radius_m }) => o.overlaps_disk(x, y, radius_m),
            (
                Obstacle::Box {
                    x: x1,
                    y: y1,
                    half_side_m: h1,
                },
                Obstacle::Box {
                    x: x2,
                    y: y2,
                    half_side_m: h2,
                },
            ) => (x1 - x2).abs() < h1 + h2 && (y1 - y2).abs() < h1 + h2,
        }
    }

    /// Time of impact along `dir` (unit) from `origin`, at most `max_m`, with parry's ray cast
    /// (solid: an origin inside gives 0).
    pub fn ray_toi(&self, origin: (f64, f64), dir: (f64, f64), max_m: f64) -> Option<f64> {
        let (cx, cy) = self.center();
        let ray = Ray::new(
            Point2::new(origin.0 - cx, origin.1 - cy),
            Vector2::new(dir.0, dir.1),
        );
        match *self {
            Obstacle::Cylinder { radius_m, .. } => {
                Ball::new(radius_m).cast_local_ray(&ray, max_m, true)
            }
            Obstacle::Box { half_side_m, .. } => {
                Cuboid::new(Vector2::new(half_side_m, half_side_m))
                    .cast_local_ray(&ray, max_m, true)
            }
        }
    }

    /// Whether the segment from `a` to `b` crosses the obstacle (line of sight blocked).
    pub fn blocks_segment(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        let (cx, cy) = self.center();
        let e = self.extent_m();
        // Cheap rejection on bounding boxes first.
        if a.0.max(b.0) < cx - e
            || a.0.min(b.0) > cx + e
            || a.1.max(b.1) < cy - e
            || a.1.min(b.1) > cy + e
        {
            return false;
        }
        let ray = Ray::new(
            Point2::new(a.0 - cx, a.1 - cy),
            Vector2::new(b.0 - a.0, b.1 - a.1),
        );
        match *self {
            Obstacle::Cylinder { radius_m, .. } => {
                Ball::new(radius_m).intersects_local_ray(&ray, 1.0)
            }
            Obstacle::Box { half_side_m, .. } => {
                Cuboid::new(Vector2::new(half_side_m, half_side_m)).intersects_local_ray(&ray, 1.0)
            }
        }
    }
}

/// A uniform grid over the arena: cell `(cx, cy)` covers
/// `[-h + cx * cell, -h + (cx + 1) * cell) x [...]`; points outside clamp to the border cells.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridShape {
    /// Half side of the arena.
    pub half_m: f64,
    /// Side of a cell.
    pub cell_m: f64,
    /// Cells per axis.
    pub cells: u32,
}

impl GridShape {
    fn new(half_m: f64, min_cell_m: f64) -> GridShape {
        let side = 2.0 * half_m;
        let cell_m = min_cell_m.max(side / f64::from(MAX_CELLS_PER_AXIS));
        let cells = ((side / cell_m).ceil() as u32).clamp(1, MAX_CELLS_PER_AXIS);
        GridShape {
            half_m,
            cell_m,
            cells,
        }
    }

    fn axis(&self, v: f64) -> u32 {
        // Truncation is floor for the non-negative values; `as` saturates large ones. (No
        // `floor` call: on baseline x86-64 it is a library call, and this is the hot path.)
        let c = (v + self.half_m) / self.cell_m;
        if c >= 0.0 {
            (c as u32).min(self.cells - 1)
        } else {
            0
        }
    }

    /// The cell holding a point.
    pub fn cell_of(&self, x: f64, y: f64) -> u32 {
        self.axis(y) * self.cells + self.axis(x)
    }

    /// Calls `f` for every cell overlapping the box `[x0, x1] x [y0, y1]`, row by row.
    pub fn for_cells(&self, x0: f64, y0: f64, x1: f64, y1: f64, mut f: impl FnMut(u32)) {
        let (ax, bx, ay, by) = (self.axis(x0), self.axis(x1), self.axis(y0), self.axis(y1));
        for cy in ay..=by {
            for cx in ax..=bx {
                f(cy * self.cells + cx);
            }
        }
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        (self.cells * self.cells) as usize
    }
}

/// The walls and the obstacles, with the obstacles indexed by grid cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Arena {
    /// Half the side of the square arena (walls at +-this).
    pub half_side_m: f64,
    /// The obstacles: cylinders first, then boxes.
    pub obstacles: Vec<Obstacle>,
    /// The grid shared by obstacles and robots.
    pub grid: GridShape,
    /// For each cell, the obstacles whose bounding box overlaps it, ascending.
    obstacle_cells: Vec<Vec<u32>>,
}

impl Arena {
    /// Places the obstacles of `w` with draws from `rng` (`Purpose::Obstacles`). `min_cell_m` is
    /// the smallest useful grid cell (the longest query radius of the world).
    pub fn new(w: &WorldConfig, rng: &mut Rng, min_cell_m: f64) -> Result<Arena, WorldError> {
        let half = w.arena_side_m / 2.0;
        let total = w.cylinders + w.boxes;
        let mut obstacles: Vec<Obstacle> = Vec::with_capacity(total as usize);
        for index in 0..total {
            let is_cylinder = index < w.cylinders;
            let extent = if is_cylinder {
                w.cylinder_radius_m
            } else {
                w.box_side_m / 2.0
            };
            let what = if is_cylinder {
                format!(
                    "obstacle {} of {total} (a cylinder of radius {} m)",
                    index + 1,
                    w.cylinder_radius_m
                )
            } else {
                format!(
                    "obstacle {} of {total} (a box of side {} m)",
                    index + 1,
                    w.box_side_m
                )
            };
            // Centers are uniform in [-s, s]^2, where the obstacle stays inside the walls.
            let inside = half - extent;
            let s = if w.obstacle_spread_half_m > 0.0 {
                w.obstacle_spread_half_m.min(inside)
            } else {
                inside
            };
            if s < 0.0 {
                return Err(WorldError::Placement {
                    what,
                    why: format!(
                        "it is larger than the arena (world.arena_side_m = {}); shrink \
                         world.cylinder_radius_m / world.box_side_m or enlarge the arena",
                        w.arena_side_m
                    ),
                });
            }
            let mut placed = None;
            for _ in 0..PLACEMENT_ATTEMPTS {
                let (x, y) = (rng.range(-s, s), rng.range(-s, s));
                let o = if is_cylinder {
                    Obstacle::Cylinder {
                        x,
                        y,
                        radius_m: extent,
                    }
                } else {
                    Obstacle::Box {
                        x,
                        y,
                        half_side_m: extent,
                    }
                };
                if obstacles.iter().all(|p| !p.overlaps(&o)) {
                    placed = Some(o);
                    break;
                }
            }
            let Some(o) = placed else {
                return Err(WorldError::Placement {
                    what,
                    why: format!(
                        "no spot free of the other obstacles after {PLACEMENT_ATTEMPTS} attempts: \
                         world.cylinders = {} (world.cylinder_radius_m = {}) and world.boxes = {} \
                         (world.box_side_m = {}) do not fit with centers in [-{s}, {s}]^2 \
                         (world.arena_side_m = {}, world.obstacle_spread_half_m = {}); use fewer or \
                         smaller obstacles, a larger spread or a larger arena",
                        w.cylinders, w.cylinder_radius_m, w.boxes, w.box_side_m, w.arena_side_m,
                        w.obstacle_spread_half_m
                    ),
                });
            };
            obstacles.push(o);
        }
        Ok(Arena::with_obstacles(half, obstacles, min_cell_m))
    }

    /// An arena with the given obstacles (indexes them in the grid).
    pub fn with_obstacles(half_side_m: f64, obstacles: Vec<Obstacle>, min_cell_m: f64) -> Arena {
        let grid = GridShape::new(half_side_m, min_cell_m);
        let mut obstacle_cells = vec![Vec::new(); grid.cell_count()];
        for (i, o) in obstacles.iter().enumerate() {
            let (x, y) = o.center();
            let e = o.extent_m();
            grid.for_cells(x - e, y - e, x + e, y + e, |c| {
                obstacle_cells[c as usize].push(i as u32)
            });
        }
        Arena {
            half_side_m,
            obstacles,
            grid,
            obstacle_cells,
        }
    }

    /// Calls `f` with the index of every obstacle whose bounding box may intersect the box
    /// `[x0, x1] x [y0, y1]` (a superset: with few obstacles, all of them); an obstacle
    /// spanning several cells may come more than once.
    pub fn obstacles_near(&self, x0: f64, y0: f64, x1: f64, y1: f64, mut f: impl FnMut(u32)) {
        if self.obstacles.len() <= FEW_OBSTACLES {
            (0..self.obstacles.len() as u32).for_each(f);
            return;
        }
        self.grid.for_cells(x0, y0, x1, y1, |c| {
            for &o in &self.obstacle_cells[c as usize] {
                f(o);
            }
        });
    }

    /// Whether a disk of radius `r` at (`x`, `y`) lies inside the walls (touching allowed).
    pub fn inside(&self, x: f64, y: f64, r: f64) -> bool {
        let lim = self.half_side_m - r;
        x.abs() <= lim && y.abs() <= lim
    }

    /// Whether a disk of radius `r` at (`x`, `y`) crosses a wall or overlaps an obstacle.
    pub fn disk_blocked(&self, x: f64, y: f64, r: f64) -> bool {
        if !self.inside(x, y, r) {
            return true;
        }
        let mut hit = false;
        self.obstacles_near(x - r, y - r, x + r, y + r, |o| {
            hit = hit || self.obstacles[o as usize].overlaps_disk(x, y, r);
        });
        hit
    }

    /// Whether an obstacle blocks the line of sight from `a` to `b`.
    pub fn occluded(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        let mut hit = false;
        self.obstacles_near(
            a.0.min(b.0),
            a.1.min(b.1),
            a.0.max(b.0),
            a.1.max(b.1),
            |o| {
                hit = hit || self.obstacles[o as usize].blocks_segment(a, b);
            },
        );
        hit
    }

    /// Distance along the unit direction `dir` from `origin` (inside the arena) to the nearest
    /// wall or obstacle, if within `max_m`.
    pub fn ray_toi(&self, origin: (f64, f64), dir: (f64, f64), max_m: f64) -> Option<f64> {
        let mut best = f64::INFINITY;
        let h = self.half_side_m;
        // Walls: the inside of the square.
        if dir.0 > 0.0 {
            best = best.min((h - origin.0) / dir.0);
        } else if dir.0 < 0.0 {
            best = best.min((-h - origin.0) / dir.0);
        }
        if dir.1 > 0.0 {
            best = best.min((h - origin.1) / dir.1);
        } else if dir.1 < 0.0 {
            best = best.min((-h - origin.1) / dir.1);
        }
        best = best.max(0.0);
        let end = (origin.0 + dir.0 * max_m, origin.1 + dir.1 * max_m);
        self.obstacles_near(
            origin.0.min(end.0),
            origin.1.min(end.1),
            origin.0.max(end.0),
            origin.1.max(end.1),
            |o| {
                if let Some(t) = self.obstacles[o as usize].ray_toi(origin, dir, max_m) {
                    best = best.min(t);
                }
            },
        );
        (best <= max_m).then_some(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_tests_allow_touching_and_catch_overlap() {
        let c = Obstacle::Cylinder {
            x: 0.0,
            y: 0.0,
            radius_m: 1.0,
        };
        let b = Obstacle::Box {
            x: 3.0,
            y: 0.0,
            half_side_m: 1.0,
        };
        assert!(!c.overlaps_disk(1.5, 0.0, 0.5));
        assert!(c.overlaps_disk(1.49, 0.0, 0.5));
        assert!(!b.overlaps_disk(1.5, 0.0, 0.5));
        assert!(b.overlaps_disk(1.51, 0.0, 0.5));
        assert!(!c.overlaps(&b));
        assert!(c.overlaps(&Obstacle::Box {
            x: 1.9,
            y: 0.0,
            half_side_m: 1.0
        }));
        // A corner: the disk near the box corner but outside the rounded distance.
        assert!(!b.overlaps_disk(4.0 + 0.3, 1.0 + 0.3, 0.42));
        assert!(b.overlaps_disk(4.0 + 0.3, 1.0 + 0.3, 0.43));
    }

    #[test]
    fn segments_and_rays_see_obstacles() {
        let arena = Arena::with_obstacles(
            2.0,
            vec![
                Obstacle::Cylinder {
                    x: 0.0,
                    y: 0.0,
                    radius_m: 0.2,
                },
                Obstacle::Box {
                    x: 1.0,
                    y: 1.0,
                    half_side_m: 0.1,
                },
            ],
            1.0,
        );
        assert!(arena.occluded((-1.0, 0.0), (1.0, 0.1)));
        assert!(!arena.occluded((-1.0, 0.5), (1.0, 0.5)));
        assert!(arena.occluded((0.5, 1.0), (1.5, 1.0)));
        assert!(!arena.occluded((0.5, 0.5), (1.5, 0.5)));
        let t = arena.ray_toi((-1.0, 0.0), (1.0, 0.0), 2.0).unwrap();
        assert!((t - 0.8).abs() < 1e-12, "{t}");
        let t = arena.ray_toi((1.9, -1.0), (1.0, 0.0), 0.5).unwrap();
        assert!((t - 0.1).abs() < 1e-12, "{t}");
        assert_eq!(arena.ray_toi((0.0, -1.0), (1.0, 0.0), 0.5), None);
    }
}

//! The robots' sensors: IR proximity rays and range-and-bearing (RAB).
//!
//! Proximity: `proximity_sensors` rays evenly spaced around the body, the first along the
//! heading, starting at the body surface, of length `proximity_range_m`; a reading is
//! `1 - distance / range` to the nearest wall, obstacle or robot (1 at contact, 0 at range or
//! with nothing in range). With `world.avoidance = "epuck"`, ARGoS's e-puck ring instead
//! (`epuck.rs`): the first ray at 11.25 degrees, rays from 1 mm off the body, at most 5 cm
//! long, and ARGoS's reading curve; with `"khepera"`, ARGoS's Khepera IV ring (`khepera.rs`):
//! rays from the body surface, at most 12 cm long, and its reading curve.
//!
//! Range-and-bearing: robot `i` is in contact with `j` when their centers are at most
//! `rab_range_m` apart and, with `rab_occlusion`, no obstacle crosses the segment between them
//! (robots occlude only with `rab_robot_occlusion`: a third robot's body meets the segment, as
//! in ARGoS). Contact is symmetric; it defines the links, the peer sets and
//! `mean_neighbours`. Each tick, each message from a contact is lost with probability
//! `rab_packet_drop` (drawn by the receiver); the peer set ignores packet drop, because gossip
//! has its own loss (`ledger.packet_loss`).

use parry2d_f64::na::{Point2, Vector2};
use parry2d_f64::query::{Ray, RayCast};
use parry2d_f64::shape::Ball;
use rayon::prelude::*;

use super::{epuck, khepera, World};
use crate::config::Avoidance;
use crate::types::RobotId;

impl World {
    /// Calls `f` for every robot that may lie within the box (a superset, by grid cell or, for
    /// a world just deserialised, every robot).
    pub(super) fn robots_near(&self, x0: f64, y0: f64, x1: f64, y1: f64, f: impl FnMut(u32)) {
        if self.scratch.grid_tick == Some(self.tick)
            && self.scratch.grid.robots() == self.poses.len()
        {
            self.scratch.grid.near(&self.arena.grid, x0, y0, x1, y1, f);
        } else {
            (0..self.poses.len() as u32).for_each(f);
        }
    }

    /// The proximity readings of `robot` in the current state, one per sensor (`out` must hold
    /// `world.proximity_sensors` values), counter-clockwise from the heading.
    pub fn proximity(&self, robot: RobotId, out: &mut [f64]) {
        let dirs = &self.params.sensor_dirs;
        assert_eq!(out.len(), dirs.len(), "one reading per proximity sensor");
        out.fill(0.0);
        let p = self.poses[robot as usize];
        let r = self.params.body.radius_m;
        let model = self.extra.avoidance;
        let (offset, range) = match model {
            Avoidance::Epuck => (
                r + epuck::RING_OFFSET_M,
                self.params.proximity_range_m.min(epuck::RANGE_M),
            ),
            Avoidance::Khepera => (
                r + khepera::RING_OFFSET_M,
                self.params.proximity_range_m.min(khepera::RANGE_M),
            ),
            Avoidance::Turn => (r, self.params.proximity_range_m),
        };
        let reach = offset + range;
        // Only cast rays when something is within reach.
        let mut robots: [u32; 16] = [0; 16];
        let mut robot_count = 0usize;
        let mut overflow = false;
        let d = reach + r;
        self.robots_near(p.x - d, p.y - d, p.x + d, p.y + d, |j| {
            let q = &self.poses[j as usize];
            if j != robot && (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y) < d * d {
                if robot_count < robots.len() {
                    robots[robot_count] = j;
                    robot_count += 1;
                } else {
                    overflow = true;
                }
            }
        });
        let mut near_static = !self.arena.inside(p.x, p.y, reach);
        if !near_static {
            self.arena
                .obstacles_near(p.x - reach, p.y - reach, p.x + reach, p.y + reach, |o| {
                    near_static = near_static
                        || self.arena.obstacles[o as usize].distance_sq(p.x, p.y) < reach * reach;
                });
        }
        if robot_count == 0 && !overflow && !near_static {
            return;
        }
        let (s, c) = libm::sincos(p.theta);
        let ball = Ball::new(r);
        for (k, &(ox, oy)) in dirs.iter().enumerate() {
            let dir = (c * ox - s * oy, s * ox + c * oy);
            let origin = (p.x + offset * dir.0, p.y + offset * dir.1);
            let mut best = if near_static {
                self.arena
                    .ray_toi(origin, dir, range)
                    .unwrap_or(f64::INFINITY)
            } else {
                f64::INFINITY
            };
            let mut cast = |j: u32| {
                if j == robot {
                    return;
                }
                let q = &self.poses[j as usize];
                let ray = Ray::new(
                    Point2::new(origin.0 - q.x, origin.1 - q.y),
                    Vector2::new(dir.0, dir.1),
                );
                if let Some(t) = ball.cast_local_ray(&ray, range, true) {
                    best = best.min(t);
                }
            };
            if overflow {
                self.robots_near(p.x - d, p.y - d, p.x + d, p.y + d, &mut cast);
            } else {
                robots[..robot_count].iter().for_each(|&j| cast(j));
            }
            if best <= range {
                out[k] = match model {
                    Avoidance::Epuck => epuck::reading(best),
                    Avoidance::Khepera => khepera::reading(best),
                    Avoidance::Turn => 1.0 - best / range,
                };
            }
        }
    }

    /// Fills `adj[i]` with the robots in range-and-bearing contact with `i`, ascending.
    pub(super) fn contacts(&self, adj: &mut Vec<Vec<RobotId>>) {
        adj.resize(self.poses.len(), Vec::new());
        adj.iter_mut().for_each(Vec::clear);
        let mut later = Vec::new();
        for i in 0..self.poses.len() {
            later.clear();
            self.contacts_after::<false>(i, &mut later);
            later.sort_unstable();
            insert(adj, i, &later);
        }
        debug_assert!(adj.iter().all(|a| a.is_sorted()));
    }

    /// [`World::contacts`] on the current rayon pool's threads (call it inside the pool's
    /// `install`: the caller's one fork then covers the sensing too), with what the next tick's physics and this
    /// tick's overlap count need from the same search: `later` holds buffers kept between
    /// ticks, one per robot; `nearest[i]` receives the squared distance from robot `i` to the
    /// nearest other robot within `rab_range_m` (infinite if none); the return value is the
    /// count of [`physics::overlaps`](super::physics::overlaps) when `rab_range_m` is at least
    /// the body's diameter (the search then sees every overlapping pair).
    ///
    /// Each robot's contacts after it are found and sorted in parallel, then every pair is
    /// inserted in robot order: `adj[i]` receives the robots before it in ascending order, then
    /// its own sorted later ones, so every list is ascending without a sort, and the lists are
    /// the sequential ones.
    pub(super) fn contacts_par(
        &self,
        adj: &mut Vec<Vec<RobotId>>,
        later: &mut Vec<Vec<RobotId>>,
        nearest: &mut Vec<f64>,
    ) -> u64 {
        let n = self.poses.len();
        adj.resize(n, Vec::new());
        adj.iter_mut().for_each(Vec::clear);
        // The per-robot buffers live between ticks: allocating a thousand lists a tick from
        // two threads at once took the two-thread world from 1.54x to 1.45x the one-thread
        // speed (docs/PERFORMANCE.md, "The parallel world and the speculation horizon").
        later.resize(n, Vec::new());
        nearest.resize(n, f64::INFINITY);
        let r = self.params.body.radius_m;
        let overlaps = later
            .par_iter_mut()
            .zip(nearest.par_iter_mut())
            .enumerate()
            .with_min_len(super::par::PIECE)
            .map(|(i, (l, near))| {
                l.clear();
                let (closest, overlapping) = self.contacts_after::<true>(i, l);
                l.sort_unstable();
                *near = closest;
                let p = self.poses[i];
                overlapping + u64::from(self.arena.disk_blocked(p.x, p.y, r))
            })
            .sum();
        for (i, l) in later.iter().enumerate() {
            insert(adj, i, l);
        }
        debug_assert!(adj.iter().all(|a| a.is_sorted()));
        overlaps
    }

    /// Pushes onto `out` the robots `j > i` in range-and-bearing contact with `i`. With `NEAR`,
    /// also returns the smallest squared distance from `i` to another robot the search visited
    /// (every robot within `rab_range_m`) and how many robots `j > i` overlap it (closer than
    /// the body's diameter: [`physics::overlaps`](super::physics::overlaps)'s test); without
    /// it, `(inf, 0)`.
    fn contacts_after<const NEAR: bool>(&self, i: usize, out: &mut Vec<RobotId>) -> (f64, u64) {
        let range = self.params.rab_range_m;
        let d = 2.0 * self.params.body.radius_m;
        let p = self.poses[i];
        let (mut closest, mut overlapping) = (f64::INFINITY, 0);
        self.robots_near(p.x - range, p.y - range, p.x + range, p.y + range, |j| {
            if j as usize == i || (!NEAR && (j as usize) < i) {
                return;
            }
            let q = &self.poses[j as usize];
            let d2 = (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y);
            if NEAR {
                closest = closest.min(d2);
                if (j as usize) < i {
                    return;
                }
                overlapping += u64::from(d2 < d * d);
            }
            if d2 <= range * range
                && !(self.params.rab_occlusion && self.arena.occluded((p.x, p.y), (q.x, q.y)))
                && !(self.extra.rab_robot_occlusion && self.robot_between(i as u32, j))
            {
                out.push(j);
            }
        });
        (closest, overlapping)
    }

    /// Whether the body of a robot other than `a` and `b` meets the segment between their
    /// centers (ARGoS's range-and-bearing medium: the first body on the ray must be the
    /// receiver's).
    fn robot_between(&self, a: RobotId, b: RobotId) -> bool {
        let p = self.poses[a as usize];
        let q = self.poses[b as usize];
        let r = self.params.body.radius_m;
        let (dx, dy) = (q.x - p.x, q.y - p.y);
        let len2 = dx * dx + dy * dy;
        let mut hit = false;
        self.robots_near(
            p.x.min(q.x) - r,
            p.y.min(q.y) - r,
            p.x.max(q.x) + r,
            p.y.max(q.y) + r,
            |k| {
                if hit || k == a || k == b {
                    return;
                }
                let c = self.poses[k as usize];
                let t = if len2 > 0.0 {
                    (((c.x - p.x) * dx + (c.y - p.y) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (p.x + t * dx - c.x, p.y + t * dy - c.y);
                hit = ex * ex + ey * ey < r * r;
            },
        );
        hit
    }

    /// The range-and-bearing links of the current state (pairs `(i, j)`, `i < j`, ascending),
    /// for drawing.
    pub fn links(&self) -> Vec<(RobotId, RobotId)> {
        let mut adj = Vec::new();
        self.contacts(&mut adj);
        let mut out = Vec::new();
        for (i, a) in adj.iter().enumerate() {
            out.extend(
                a.iter()
                    .filter(|&&j| j as usize > i)
                    .map(|&j| (i as RobotId, j)),
            );
        }
        out
    }
}

/// Inserts robot `i`'s contacts after it (ascending) into both lists of each pair.
fn insert(adj: &mut [Vec<RobotId>], i: usize, later: &[RobotId]) {
    for &j in later {
        adj[i].push(j);
        adj[j as usize].push(i as u32);
    }
}

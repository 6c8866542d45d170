//! `mirror-targets`: data poisoning in the spirit of label flipping (ByzFL's `LabelFlipping`
//! maps every label `l` to `L - 1 - l`, a fixed permutation of the target space). For
//! trajectories the analogous permutation swaps left and right: every target waypoint `p` is
//! mirrored across the robot's heading line, the line through the last input waypoint `o` in
//! the direction `d = o - o'` of the last input step (`o'` the waypoint before `o`),
//!
//! `p' = o + 2 ((p - o) . d / |d|^2) d - (p - o)`,
//!
//! so a robot that turned left is learned as turning right and vice versa, while speed and the
//! straight-ahead part stay true (unlike `poison-data`, which reverses the whole future). The
//! robot trains honestly, by the same procedure as every robot, on these samples and submits
//! the result with its real training samples. Samples with fewer than two input waypoints, no
//! target, or a standing robot (`d = 0`) are kept as they are. Computed in `f64` without fused
//! multiply-add and rounded once to `f32`.
//!
//! Information: its own trajectories, w(t) (the training starts from it). Parameters: none
//! beyond the learning ones (`data.input_waypoints` splits input from target).

use super::{Action, Attack, View};
use crate::data::Sample;
use crate::rng::Rng;

/// The `mirror-targets` agent.
pub struct MirrorTargets;

/// `samples` with every target waypoint mirrored across the heading line of the last two of
/// the first `inputs` waypoints.
pub fn mirror(samples: &[Sample], inputs: usize) -> Vec<Sample> {
    samples
        .iter()
        .map(|s| {
            let mut s = s.clone();
            if inputs < 2 || inputs >= s.points.len() {
                return s;
            }
            let (prev, o) = (s.points[inputs - 2], s.points[inputs - 1]);
            let (ox, oy) = (f64::from(o[0]), f64::from(o[1]));
            let (dx, dy) = (ox - f64::from(prev[0]), oy - f64::from(prev[1]));
            let len2 = dx * dx + dy * dy;
            if len2 == 0.0 {
                return s;
            }
            for p in &mut s.points[inputs..] {
                let (rx, ry) = (f64::from(p[0]) - ox, f64::from(p[1]) - oy);
                let t = 2.0 * (rx * dx + ry * dy) / len2;
                *p = [(ox + t * dx - rx) as f32, (oy + t * dy - ry) as f32];
            }
            s
        })
        .collect()
}

impl Attack for MirrorTargets {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        Action::Train {
            samples: mirror(&view.own_dataset(), view.input_waypoints),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::SimTime;

    #[test]
    fn targets_are_mirrored_across_the_heading() {
        // Heading along +x from (0, 0) to (1, 0): a left turn (2, 1), (3, 2) becomes the right
        // turn (2, -1), (3, -2); straight ahead stays.
        let s = Sample {
            time: SimTime(0),
            points: vec![[0.0, 0.0], [1.0, 0.0], [2.0, 1.0], [3.0, 2.0], [4.0, 0.0]],
        };
        let m = mirror(&[s], 2);
        assert_eq!(
            m[0].points,
            vec![[0.0, 0.0], [1.0, 0.0], [2.0, -1.0], [3.0, -2.0], [4.0, 0.0]]
        );
    }

    #[test]
    fn a_diagonal_heading_and_the_kept_cases() {
        // Heading along (1, 1) through (1, 1): (1, 2) (left of the heading) -> (2, 1).
        let s = Sample {
            time: SimTime(0),
            points: vec![[0.0, 0.0], [1.0, 1.0], [1.0, 2.0]],
        };
        assert_eq!(mirror(std::slice::from_ref(&s), 2)[0].points[2], [2.0, 1.0]);
        // One input waypoint, no target, a standing robot: unchanged.
        assert_eq!(mirror(std::slice::from_ref(&s), 1)[0], s);
        assert_eq!(mirror(std::slice::from_ref(&s), 3)[0], s);
        let standing = Sample {
            time: SimTime(0),
            points: vec![[1.0, 1.0], [1.0, 1.0], [5.0, 2.0]],
        };
        assert_eq!(mirror(std::slice::from_ref(&standing), 2)[0], standing);
    }
}

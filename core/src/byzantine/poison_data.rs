//! `poison-data`: trains honestly, by the same procedure as every robot, on its own
//! trajectories with the targets corrupted: every target waypoint `p` is reflected through the
//! last input waypoint `o`, `p' = 2 o - p`, so the robot learns that a robot turns back on its
//! path. The submission is a genuinely trained model (it passes any check an honest model
//! passes, until the swarm's models drift apart) claiming its real training samples.
//!
//! Information: its own trajectories, w(t) (the training starts from it, as honest training
//! does). Parameters: none beyond the learning ones (`data.input_waypoints` splits input from
//! target).

use super::{Action, Attack, View};
use crate::data::Sample;
use crate::rng::Rng;

/// The `poison-data` agent.
pub struct PoisonData;

/// `samples` with every target waypoint reflected through the last of the first `inputs`
/// waypoints. Samples with no input or no target are kept as they are.
pub fn poison(samples: &[Sample], inputs: usize) -> Vec<Sample> {
    samples
        .iter()
        .map(|s| {
            let mut s = s.clone();
            if inputs >= 1 && inputs < s.points.len() {
                let o = s.points[inputs - 1];
                for p in &mut s.points[inputs..] {
                    *p = [2.0 * o[0] - p[0], 2.0 * o[1] - p[1]];
                }
            }
            s
        })
        .collect()
}

impl Attack for PoisonData {
    fn act(&self, view: &View, _rng: &mut Rng) -> Action {
        Action::Train {
            samples: poison(&view.own_dataset(), view.input_waypoints),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::SimTime;

    #[test]
    fn targets_are_reflected_through_the_last_input() {
        let s = Sample {
            time: SimTime(0),
            points: vec![[0.0, 0.0], [1.0, 1.0], [2.0, 1.0], [3.0, 0.5]],
        };
        let p = poison(&[s], 2);
        assert_eq!(
            p[0].points,
            vec![[0.0, 0.0], [1.0, 1.0], [0.0, 1.0], [-1.0, 1.5]]
        );
    }
}

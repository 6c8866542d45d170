//! The obstacle avoidance of Flow-FL's robots on ARGoS's Khepera IV (`world.avoidance =
//! "khepera"`, the `flowfl` preset; docs/SPEC.md section 1, "Data volume"). Two parts, each as
//! Flow-FL ran it:
//!
//! - The sensors (NESTLab/argos3-kheperaiv, `kheperaiv_entity.cpp`, `kheperaiv_measures.cpp`
//!   and `kheperaiv_proximity_default_sensor.cpp`): a ring of 8 rays counter-clockwise from
//!   the heading (start angle 0, 45 degrees apart), starting at the body surface (ring radius
//!   = body radius 0.0704 m), 12 cm long; a hit at distance `d` along the ray reads 1 below
//!   4 cm and `4.14 exp(-33 d) - 0.085` beyond (0.2 at 8.1 cm, 0 at 11.78 cm). ARGoS leaves
//!   the curve's small negative values between 11.78 and 12 cm; they are clamped to 0 here,
//!   which no rule reads differently (Flow-FL's tests `> 0`).
//! - The rule (NESTLab/TrajectoryCollection,
//!   `argos-scripts/controllers/khepera_obstacleavoidance/khepera_obstacleavoidance.cpp`,
//!   `ControlStep`): the largest reading among sensors 0, 1, 7 and 6 (0, 45, -45 and -90
//!   degrees; the first of equal ones in that order); above the threshold (0 in Flow-FL) the
//!   robot pivots on one wheel, away from it: the left wheel at the cruise speed and the right
//!   one stopped (a clockwise pivot) for sensors 0 and 1, the mirror image for 7 and 6. Below
//!   it, straight at the cruise speed. The choice is made afresh every tick: no memory, no
//!   random walk. Sensor 2 (90 degrees) is not read, as in Flow-FL, so the rule is not
//!   symmetric: a robot follows a wall on its left and turns away from one on its right.

/// The rays start at the body surface (`KHEPERAIV_IR_SENSORS_RING_RADIUS` = the body radius).
pub(super) const RING_OFFSET_M: f64 = 0.0;

/// Length of every ray (`KHEPERAIV_IR_SENSORS_RING_RANGE`).
pub(super) const RANGE_M: f64 = 0.12;

/// The sensors the rule reads, in the order Flow-FL compares them (the first maximum wins).
const FRONT: [usize; 4] = [0, 1, 7, 6];

/// ARGoS's Khepera IV reading of an obstacle at `d` metres along the ray.
pub(super) fn reading(d: f64) -> f64 {
    if d < 0.04 {
        1.0
    } else if d > RANGE_M {
        0.0
    } else {
        (4.14 * libm::exp(-33.0 * d) - 0.085).clamp(0.0, 1.0)
    }
}

/// Flow-FL's avoidance command `(left, right)` in m/s, if the largest front reading is above
/// `threshold`; `None` means "no obstacle" (drive on).
pub(super) fn avoid(readings: &[f64], threshold: f64, cruise_mps: f64) -> Option<(f64, f64)> {
    assert!(
        readings.len() >= 8,
        "the Khepera IV has 8 proximity sensors"
    );
    let mut best = FRONT[0];
    for &k in &FRONT[1..] {
        if readings[best] < readings[k] {
            best = k;
        }
    }
    if readings[best] <= threshold {
        return None;
    }
    Some(if best <= 1 {
        (cruise_mps, 0.0)
    } else {
        (0.0, cruise_mps)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reading_curve_is_argos_calibration() {
        assert_eq!(reading(0.0), 1.0);
        assert_eq!(reading(0.039), 1.0);
        let at = |d: f64| 4.14 * (-33.0 * d).exp() - 0.085;
        assert!((reading(0.06) - at(0.06)).abs() < 1e-12);
        assert!((reading(0.0811) - 0.2).abs() < 0.002, "{}", reading(0.0811));
        assert!(reading(0.117) > 0.0);
        assert_eq!(reading(0.119), 0.0);
        assert_eq!(reading(0.13), 0.0);
    }

    #[test]
    fn the_robot_pivots_away_from_the_largest_front_reading_and_ignores_its_left_side() {
        let cmd = |pairs: &[(usize, f64)]| {
            let mut r = [0.0; 8];
            for &(k, v) in pairs {
                r[k] = v;
            }
            avoid(&r, 0.0, 0.05)
        };
        // Front (sensor 0) and front-left (1): clockwise, on the left wheel.
        assert_eq!(cmd(&[(0, 0.3)]), Some((0.05, 0.0)));
        assert_eq!(cmd(&[(1, 0.3), (7, 0.2)]), Some((0.05, 0.0)));
        // Front-right (7) and right (6): counter-clockwise.
        assert_eq!(cmd(&[(7, 0.3), (1, 0.2)]), Some((0.0, 0.05)));
        assert_eq!(cmd(&[(6, 0.1)]), Some((0.0, 0.05)));
        // A tie goes to the first in Flow-FL's order 0, 1, 7, 6.
        assert_eq!(cmd(&[(7, 0.3), (0, 0.3)]), Some((0.05, 0.0)));
        // The left side (2), the back (3, 4, 5) and nothing at all: straight on.
        assert_eq!(cmd(&[(2, 0.9), (3, 0.9), (4, 0.9), (5, 0.9)]), None);
        assert_eq!(cmd(&[]), None);
    }
}

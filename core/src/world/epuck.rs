//! The obstacle avoidance of the paper's code on ARGoS's e-puck (`world.avoidance = "epuck"`,
//! docs/SPEC.md section 1, "Data volume"). Two parts, each as the authors ran it:
//!
//! - The sensors (demiurge-project/argos3-epuck, `epuck_entity.cpp` and
//!   `epuck_proximity_default_sensor.cpp`): 8 rays counter-clockwise from 11.25 degrees
//!   (`PROXIMITY_SENSOR_RING_START_ANGLE` = pi/16, 45 degrees apart), starting 1 mm off the
//!   body (`PROXIMITY_SENSOR_RING_RADIUS`), 5 cm long; the reading of a hit at distance `d`
//!   along the ray is `298.701 d^2 - 36.8961 d + 1.08212` clamped to [0, 1] (1 up to 2 mm,
//!   0.2 at 3.24 cm, 0 from 4.79 cm), 0 without a hit.
//! - The rule (teksander/geth-argos, `TrajectoryPrediction/controllers/movement.py`,
//!   `RandomWalk.step` and `RandomWalk.avoid`): with `W` the sum over the sensors reading
//!   above the threshold of weight x reading, weights `[-10, -10, 0, 0, 0, 0, 10, 10]` cm/s
//!   (the code writes `50 * [...]`, which in Python repeats the list; only its first 8
//!   entries are read), the command is `base - W` on the left wheel and `base + W` on the
//!   right, `base` half the cruise speed, both scaled down together so that neither exceeds
//!   the cruise speed (`saturate_seb`). The code computes `left = base + W` and passes
//!   `set_speed(right, left)` to a wrapper whose arguments are (left, right) (KenN7/argos-python
//!   `CEPuckWheelsWrapper::SetSpeed`), hence the signs here: an obstacle on sensors 0-1 (front
//!   left) speeds the left wheel and turns the robot clockwise, away. A robot seeing only
//!   side or rear sensors above the threshold (weight 0) drives straight at half speed. With
//!   no sensor above the threshold it drives straight at the cruise speed (the code's random
//!   walk is commented out; our random turns still apply if `world.random_turn_rate_per_s`
//!   is not 0).

/// Angle of sensor 0 from the heading (ARGoS e-puck `PROXIMITY_SENSOR_RING_START_ANGLE`).
pub(super) const START_ANGLE: f64 = std::f64::consts::PI / 16.0;

/// The rays start this far outside the body (`PROXIMITY_SENSOR_RING_RADIUS` = body + 1 mm).
pub(super) const RING_OFFSET_M: f64 = 0.001;

/// Farthest distance along a ray that reads above 0 (`PROXIMITY_SENSOR_RING_RANGE`).
pub(super) const RANGE_M: f64 = 0.05;

/// Wheel-speed weight of each sensor per unit of reading, in m/s (the code's cm/s / 100).
const WEIGHTS_MPS: [f64; 8] = [-0.1, -0.1, 0.0, 0.0, 0.0, 0.0, 0.1, 0.1];

/// ARGoS's e-puck reading of an obstacle at `d` metres along the ray.
pub(super) fn reading(d: f64) -> f64 {
    if d <= RANGE_M {
        (298.701 * d * d - 36.8961 * d + 1.08212).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The authors' avoidance command `(left, right)` in m/s, if any sensor reads above
/// `threshold`; `None` means "no obstacle" (drive on).
pub(super) fn avoid(readings: &[f64], threshold: f64, cruise_mps: f64) -> Option<(f64, f64)> {
    let mut obstacle = false;
    let mut w = 0.0;
    for (&r, &weight) in readings.iter().zip(&WEIGHTS_MPS) {
        if r > threshold {
            obstacle = true;
            w += weight * r;
        }
    }
    if !obstacle {
        return None;
    }
    let base = 0.5 * cruise_mps;
    let (left, right) = (base - w, base + w);
    let most = left.abs().max(right.abs());
    Some(if most > cruise_mps {
        (left * cruise_mps / most, right * cruise_mps / most)
    } else {
        (left, right)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reading_curve_is_argos_calibration() {
        assert_eq!(reading(0.0), 1.0);
        assert!((reading(0.0324) - 0.2).abs() < 0.002, "{}", reading(0.0324));
        assert_eq!(reading(0.048), 0.0);
        assert_eq!(reading(0.051), 0.0);
    }

    #[test]
    fn an_obstacle_front_left_turns_the_robot_clockwise_and_one_at_the_side_slows_it() {
        // Sensor 0 (11.25 degrees, left of the heading) at reading 0.5: left 1.25 + 5 = 6.25,
        // right 1.25 - 5 = -3.75 cm/s, saturated to 2.5 and -1.5.
        let mut r = [0.0; 8];
        r[0] = 0.5;
        let (left, right) = avoid(&r, 0.2, 0.025).unwrap();
        assert!((left - 0.025).abs() < 1e-12 && (right + 0.015).abs() < 1e-12);
        // The mirror image: sensor 7 (-33.75 degrees, right) turns it counter-clockwise.
        let mut r = [0.0; 8];
        r[7] = 0.5;
        let (left, right) = avoid(&r, 0.2, 0.025).unwrap();
        assert!(right > 0.0 && left < 0.0);
        // Only sensor 2 (101.25 degrees) above the threshold: straight at half speed.
        let mut r = [0.0; 8];
        r[2] = 0.9;
        assert_eq!(avoid(&r, 0.2, 0.025), Some((0.0125, 0.0125)));
        // Below the threshold: nothing to avoid.
        r[2] = 0.2;
        assert_eq!(avoid(&r, 0.2, 0.025), None);
    }
}

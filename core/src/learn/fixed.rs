//! Conversion between training weights (`f32`) and the on-chain fixed point (`i64` of
//! `scale` units per 1.0; scale 1e9 as the reference's int48).

/// Bound on |w| * scale: the reference stores weights as int48.
pub const FIXED_LIMIT: f64 = (1u64 << 47) as f64;

/// A weight that cannot be put on chain.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FixedPointError {
    /// NaN or infinite weight (a diverged training).
    #[error(
        "weight {index} is {value}, not a finite number: the training diverged; do not submit it"
    )]
    NonFinite {
        /// Position in the flat layout.
        index: usize,
        /// The value.
        value: f32,
    },
    /// |w| * scale does not fit in 48 signed bits.
    #[error("weight {index} = {value} times scale {scale} is outside +-2^47 (int48 on chain)")]
    OutOfRange {
        /// Position in the flat layout.
        index: usize,
        /// The value.
        value: f32,
        /// The scale used.
        scale: u64,
    },
    /// The scale is zero.
    #[error("fixed-point scale is 0; contract.weight_scale must be positive")]
    ZeroScale,
}

/// `round(w * scale)` for every weight, rounding half away from zero. The product is taken in
/// f64, where it is exact for scale 1e9 (= 2^9 5^9, and 24 + 21 bits fit in 53).
pub fn to_fixed(weights: &[f32], scale: u64) -> Result<Vec<i64>, FixedPointError> {
    if scale == 0 {
        return Err(FixedPointError::ZeroScale);
    }
    let s = scale as f64;
    weights
        .iter()
        .enumerate()
        .map(|(index, &value)| {
            if !value.is_finite() {
                return Err(FixedPointError::NonFinite { index, value });
            }
            let v = (f64::from(value) * s).round();
            if v.abs() >= FIXED_LIMIT {
                return Err(FixedPointError::OutOfRange {
                    index,
                    value,
                    scale,
                });
            }
            Ok(v as i64)
        })
        .collect()
}

/// `w / scale` (f64 division, then rounded to f32). A zero scale gives NaN weights.
pub fn from_fixed(weights: &[i64], scale: u64) -> Vec<f32> {
    let s = scale as f64;
    weights.iter().map(|&v| (v as f64 / s) as f32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(w: f32, expect: Result<i64, FixedPointError>) {
        let got = to_fixed(&[0.0, w], 1_000_000_000).map(|v| v[1]);
        let expect = expect.map_err(|e| match e {
            FixedPointError::NonFinite { value, .. } => {
                FixedPointError::NonFinite { index: 1, value }
            }
            FixedPointError::OutOfRange { value, scale, .. } => FixedPointError::OutOfRange {
                index: 1,
                value,
                scale,
            },
            e => e,
        });
        match (&got, &expect) {
            (
                Err(FixedPointError::NonFinite { value: a, index: i }),
                Err(FixedPointError::NonFinite { value: b, index: j }),
            ) => {
                assert_eq!((a.to_bits(), i), (b.to_bits(), j));
            }
            _ => assert_eq!(got, expect, "to_fixed({w})"),
        }
    }

    #[test]
    fn conversions() {
        check(0.5, Ok(500_000_000));
        check(-0.25, Ok(-250_000_000));
        check(1.0e-9, Ok(1));
        check(-1.5e-9, Ok(-2)); // -1.5e-9 in f32 is slightly above 1.5e-9 in magnitude
        check(2.5e-10, Ok(0));
        check(100_000.0, Ok(100_000_000_000_000));
        check(
            f32::NAN,
            Err(FixedPointError::NonFinite {
                index: 1,
                value: f32::NAN,
            }),
        );
        check(
            f32::INFINITY,
            Err(FixedPointError::NonFinite {
                index: 1,
                value: f32::INFINITY,
            }),
        );
        check(
            150_000.0,
            Err(FixedPointError::OutOfRange {
                index: 1,
                value: 150_000.0,
                scale: 1_000_000_000,
            }),
        );
        check(
            -150_000.0,
            Err(FixedPointError::OutOfRange {
                index: 1,
                value: -150_000.0,
                scale: 1_000_000_000,
            }),
        );
        assert_eq!(to_fixed(&[1.0], 0), Err(FixedPointError::ZeroScale));
        let msg = to_fixed(&[0.0, 0.0, f32::NAN], 1_000_000_000)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("weight 2") && msg.contains("NaN"), "{msg}");
    }

    #[test]
    fn round_trip_is_within_half_a_unit_and_exact_for_coarse_values() {
        let scale = 1_000_000_000;
        let mut rng = crate::rng::stream(3, crate::rng::Purpose::ModelInit, 0);
        let w: Vec<f32> = (0..5000).map(|_| (rng.normal() * 0.3) as f32).collect();
        let back = from_fixed(&to_fixed(&w, scale).unwrap(), scale);
        for (a, b) in w.iter().zip(&back) {
            // The f32 spacing near a is above 2e-9 for |a| > 0.03: then the round trip is exact.
            assert!((f64::from(*a) - f64::from(*b)).abs() <= 0.5e-9 + f64::from(a.abs()) * 1e-7);
            if a.abs() > 0.03 {
                assert_eq!(a.to_bits(), b.to_bits(), "{a} came back as {b}");
            }
        }
        // Fixed -> float -> fixed is the identity while the f32 spacing stays below 1e-9.
        let ints: Vec<i64> = (-10_000..10_000).map(|i| i * 997).collect();
        assert_eq!(to_fixed(&from_fixed(&ints, scale), scale).unwrap(), ints);
    }
}

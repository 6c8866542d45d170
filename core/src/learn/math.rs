//! The activations of training, `exp`, the logistic sigmoid and `tanh`, built from IEEE basic
//! operations only (+, -, *, / and bit operations), in a fixed order, with at most one division
//! per value.
//!
//! What the simulator needs from these is the same bits on every machine, kernel and thread
//! count, and the accuracy of a Keras trainer (TensorFlow's CPU kernels use Eigen's rational
//! approximations, not libm). Every step below is one correctly rounded IEEE operation (Rust
//! never contracts `a * b + c` into a fused multiply-add, and nothing is reassociated) or an
//! exact integer operation on bits, so the scalar code, its auto-vectorised baseline compilation
//! and its AVX2 and AVX-512 compilations give the same bits for every input; there is no table
//! and no instruction whose result depends on the CPU (no `rcp`/`rsqrt` estimates).
//!
//! - `exp(x)`: Cody-Waite reduction `x = k ln2 + r` with `k = round(x / ln2)` (rounded by the
//!   1.5 * 2^23 shift) and ln 2 split into a 15-bit head (so `k * LN2_HI` is exact for
//!   |k| < 256) and a tail; the rounding error of `r` is kept (`rc`). Then
//!   `e^r = 1 + r + r^2 P(r)` with a degree-4 minimax `P` on |r| <= 0.3486, the sum `1 + r`
//!   split exactly into head and rounding error (Fast2Sum), so that only the last addition
//!   rounds at full weight. Finally `* 2^k1 * 2^k2` with `k1 + k2 = k` built from exponent
//!   bits: the first product is exact and the second rounds once, also into the subnormal range
//!   and to infinity. The argument is clamped to [-105, 89] first (results 0 and +inf there).
//! - `sigmoid(x) = num / (1 + e)` with `e = exp(-|x|)` and `num = 1` for x >= 0, `num = e` for
//!   x < 0 (`e^x / (1 + e^x)`): one division, `exp` never overflows, and the tiny results of
//!   very negative x (down to the subnormals) keep their relative accuracy. The rounding error
//!   of `1 + e` is corrected to first order (it would cost up to 1 ulp of the quotient).
//! - `tanh(x)`: for |x| < 0.55 the odd minimax polynomial `a + a s Q(s)`, `s = a^2`, `Q` of
//!   degree 4 (relative accuracy near 0, where `1 - 2 / (e^2a + 1)` would cancel); above,
//!   `1 - 2 / (exp(2 min(a, 10)) + 1)`, whose result is at least 0.5 there, so the quotient's error
//!   counts at most half; the sign is put back by bits (tanh(-0) = -0). A chunk of lanes that
//!   all take one form computes only that form; a mixed chunk computes both for every lane
//!   (branch-free, so it vectorises) and selects one per lane, which gives the same bits. The
//!   only division is the one of the second form.
//!
//! Accuracy, checked on all 2^32 inputs against an f64 reference by `SWARMFL_EXHAUSTIVE=1
//! cargo test --release -p swarmfl-core exhaustive` (without the variable, every 65537th
//! input): at most 1 ulp from the correctly rounded value for each of the three (the test
//! allows the 2 ulp of the specification and prints the largest errors it saw).

/// Width of the chunks the slice functions process (one AVX-512 vector, two AVX2 vectors); any
/// slice length is accepted (the tail runs lane by lane through the same code).
pub const LANES: usize = 16;

/// 1 / ln 2, rounded.
const INV_LN2: f32 = f32::from_bits(0x3fb8_aa3b);
/// ln 2 to 15 significant bits: `k * LN2_HI` is exact for |k| < 256.
const LN2_HI: f32 = f32::from_bits(0x3f31_7200);
/// ln 2 - LN2_HI, rounded.
const LN2_LO: f32 = f32::from_bits(0x35bf_be8e);
/// 1.5 * 2^23: adding it rounds a value of magnitude below 2^22 to an integer (ties to even),
/// which then sits in the low bits of the sum's significand.
const ROUND_SHIFT: f32 = 12_582_912.0;
/// `exp` is +inf above this (e^89 > f32::MAX) and the clamp keeps `k` at most 128.
const EXP_CLAMP_HI: f32 = 89.0;
/// `exp` is 0 below this (e^-105 is under half the smallest subnormal); `k` stays >= -152.
const EXP_CLAMP_LO: f32 = -105.0;
/// `P(r) = E2 + E3 r + E4 r^2 + E5 r^3 + E6 r^4 ~ (e^r - 1 - r) / r^2` on |r| <= 0.3486
/// (minimax for the relative error of e^r, 3.2e-9; coefficients rounded to f32).
const E2: f32 = f32::from_bits(0x3eff_fffe);
const E3: f32 = f32::from_bits(0x3e2a_aa46);
const E4: f32 = f32::from_bits(0x3d2a_ac83);
const E5: f32 = f32::from_bits(0x3c09_1ea6);
const E6: f32 = f32::from_bits(0x3ab5_0f46);
/// `Q(s) = T3 + T5 s + T7 s^2 + T9 s^3 + T11 s^4 ~ (tanh(a) - a) / a^3`, s = a^2, on
/// 0 <= a <= 0.5501 (minimax for the relative error of tanh, 1.0e-9; rounded to f32).
const T3: f32 = f32::from_bits(0xbeaa_aaa5);
const T5: f32 = f32::from_bits(0x3e08_8692);
const T7: f32 = f32::from_bits(0xbd5c_941f);
const T9: f32 = f32::from_bits(0x3cac_9d76);
const T11: f32 = f32::from_bits(0xbbcd_91cc);
/// `tanh` takes the polynomial below this |x| and `1 - 2 / (e^2|x| + 1)` from it on
/// (tanh(0.55) = 0.5005: the second form's result is at least 0.5).
const TANH_POLY_BELOW: f32 = 0.55;
/// tanh(x) rounds to 1 from 9.01 on; the exponential form is evaluated at most at 10.
const TANH_CLAMP: f32 = 10.0;

/// 2^k from exponent bits, for k in [-126, 127] (callers keep it there; out of range the bits
/// wrap, which only NaN lanes can reach, and their result is NaN whatever the factor).
#[inline(always)]
fn pow2(k: i32) -> f32 {
    f32::from_bits((k.wrapping_add(127) as u32) << 23)
}

/// The reduction and polynomial of `exp`: `(y, k)` with `e^x = y * 2^k`, `y` in [0.70, 1.42]
/// and `k = round(x / ln 2)`, for `x` in [`EXP_CLAMP_LO`, `EXP_CLAMP_HI`] or NaN (the callers
/// clamp, or know their argument is in range).
#[inline(always)]
fn exp_parts(x: f32) -> (f32, i32) {
    // k = round(x / ln 2) in [-152, 128], as a float and as an integer from the sum's bits.
    let shifted = x * INV_LN2 + ROUND_SHIFT;
    let kf = shifted - ROUND_SHIFT;
    let k = (shifted.to_bits() as i32).wrapping_sub(ROUND_SHIFT.to_bits() as i32);
    // r = x - k ln 2: `kf * LN2_HI` is exact and so is its difference from x (Cody-Waite);
    // `r` rounds once, and `rc` is that rounding error (the tail product's own error is below
    // 2^-40 of the result).
    let hi = x - kf * LN2_HI;
    let lo = kf * LN2_LO;
    let r = hi - lo;
    let rc = (hi - r) - lo;
    // e^r = 1 + r + r^2 P(r). `one_r = 1 + r` rounds, `e1` is its exact error (Fast2Sum: 1 is
    // at least |r|), so the one rounding at the result's weight is the last addition.
    let p = r * r * (E2 + r * (E3 + r * (E4 + r * (E5 + r * E6))));
    let one_r = 1.0 + r;
    let e1 = r - (one_r - 1.0);
    (one_r + ((e1 + rc) + p), k)
}

/// `e^x` of one value (see the module documentation), branch-free so that a loop over lanes
/// vectorises. NaN gives NaN, +inf gives +inf, -inf gives +0.
#[inline(always)]
pub fn exp_lane(x: f32) -> f32 {
    // Comparisons are false for NaN, so NaN passes through both clamps (and yields NaN below).
    let x = if x > EXP_CLAMP_HI { EXP_CLAMP_HI } else { x };
    exp_le_hi(x)
}

/// [`exp_lane`] for `x <= EXP_CLAMP_HI` or NaN: the same bits without the upper clamp (which
/// does nothing there). The sigmoid's argument `-|x|` is never positive.
#[inline(always)]
fn exp_le_hi(x: f32) -> f32 {
    let x = if x < EXP_CLAMP_LO { EXP_CLAMP_LO } else { x };
    let (y, k) = exp_parts(x);
    // y * 2^k in two factors, each a normal power of two: y * 2^k1 is exact, the second
    // product rounds once (into the subnormals, or to +inf for k = 128 and y >= 1).
    let k1 = k >> 1;
    y * pow2(k1) * pow2(k.wrapping_sub(k1))
}

/// [`exp_lane`] for `x` in [0, 2 * TANH_CLAMP] or NaN (the exponential of tanh), the same bits
/// in fewer operations: neither clamp acts there, and with `k` in [0, 29] the power of two is
/// one normal factor, `y * 2^k` exact (the two factors of the general case give the same
/// exact product). A NaN `x` makes `y` NaN whatever the factor.
#[inline(always)]
fn exp_tanh_range(x: f32) -> f32 {
    let (y, k) = exp_parts(x);
    y * pow2(k)
}

/// The logistic sigmoid `1 / (1 + e^-x)` of one value with one division: `1 / (1 + e)` for
/// x >= 0 and `e / (1 + e)` for x < 0, where `e = e^-|x|` <= 1. NaN gives NaN, +-0 gives 0.5,
/// +inf gives 1, -inf gives +0.
#[inline(always)]
pub fn sigmoid_lane(x: f32) -> f32 {
    let a = f32::from_bits(x.to_bits() & 0x7fff_ffff);
    let e = exp_le_hi(-a);
    let neg = x < 0.0;
    let num = if neg { e } else { 1.0 };
    // The rounding of the divisor 1 + e alone costs up to 1 ulp of the quotient (e/(1 + e)
    // at the bottom of a binade: 2.4 ulp in all, measured), so it is corrected: `d_lo` is its
    // exact error (Fast2Sum, 1 >= e), and num / (d + d_lo) = q (1 - d_lo / d) to first order,
    // with 1 / d taken as the sigmoid itself (q for x >= 0, 1 - q for x < 0; the first-order
    // term is below 2^-24 of q, so this estimate's error does not show).
    let d = 1.0 + e;
    let d_lo = e - (d - 1.0);
    let q = num / d;
    let inv_d = if neg { 1.0 - q } else { q };
    q - q * (d_lo * inv_d)
}

/// `tanh` of one value (see the module documentation), branch-free, one division. Odd to the
/// bit (tanh(-x) = -tanh(x), tanh(-0) = -0); +-inf gives +-1, NaN gives NaN.
#[inline(always)]
pub fn tanh_lane(x: f32) -> f32 {
    let sign = x.to_bits() & 0x8000_0000;
    let a = f32::from_bits(x.to_bits() & 0x7fff_ffff);
    // NaN fails the comparison and takes the exponential form, which is NaN.
    let r = if a < TANH_POLY_BELOW {
        tanh_small(a)
    } else {
        tanh_big(a)
    };
    f32::from_bits(r.to_bits() | sign)
}

/// tanh(a) for 0 <= a < [`TANH_POLY_BELOW`]: `a + a s Q(s)`. Subnormal a: s underflows to 0
/// and the result is a, exactly.
#[inline(always)]
fn tanh_small(a: f32) -> f32 {
    let s = a * a;
    a + a * (s * (T3 + s * (T5 + s * (T7 + s * (T9 + s * T11)))))
}

/// tanh(a) for a >= [`TANH_POLY_BELOW`] (or NaN): `1 - 2 / (e^2a + 1)`, with a clamped to 10
/// (tanh(10) rounds to 1, and e^2a stays finite; NaN passes the clamp). As in the sigmoid, the
/// rounding error `d_lo` of the divisor (Fast2Sum, e^2a > 1) is corrected to first order, with
/// 1 / d = q / 2 (1.49 ulp at 0.556 without it, measured).
#[inline(always)]
fn tanh_big(a: f32) -> f32 {
    let ac = if a > TANH_CLAMP { TANH_CLAMP } else { a };
    let e = exp_tanh_range(ac + ac);
    let d = e + 1.0;
    let d_lo = 1.0 - (d - e);
    let q = 2.0 / d;
    1.0 - (q - q * (d_lo * (0.5 * q)))
}

/// Replaces every value by its `tanh` ([`tanh_lane`], bit for bit). A chunk whose lanes all
/// take the same form of [`tanh_lane`] computes only that form (the polynomial alone skips
/// the exponential and the division); a mixed chunk computes both and selects per lane, as
/// `tanh_lane` does. Either way each lane's bits are `tanh_lane`'s.
#[inline(always)]
pub fn tanh_in_place(values: &mut [f32]) {
    let mut chunks = values.chunks_exact_mut(LANES);
    for chunk in &mut chunks {
        let mut lanes = [0f32; LANES];
        lanes.copy_from_slice(chunk);
        // The magnitudes' bits order like the magnitudes (NaN above +inf), so the largest and
        // smallest bits say whether every lane is below the switch, or every lane at or above
        // it (NaN included, as in `tanh_lane`).
        let (mut most, mut least) = (0u32, u32::MAX);
        for v in &lanes {
            let m = v.to_bits() & 0x7fff_ffff;
            most = most.max(m);
            least = least.min(m);
        }
        let switch = TANH_POLY_BELOW.to_bits();
        if most < switch {
            for v in lanes.iter_mut() {
                let sign = v.to_bits() & 0x8000_0000;
                let a = f32::from_bits(v.to_bits() & 0x7fff_ffff);
                *v = f32::from_bits(tanh_small(a).to_bits() | sign);
            }
        } else if least >= switch {
            for v in lanes.iter_mut() {
                let sign = v.to_bits() & 0x8000_0000;
                let a = f32::from_bits(v.to_bits() & 0x7fff_ffff);
                *v = f32::from_bits(tanh_big(a).to_bits() | sign);
            }
        } else {
            for v in lanes.iter_mut() {
                *v = tanh_lane(*v);
            }
        }
        chunk.copy_from_slice(&lanes);
    }
    for v in chunks.into_remainder() {
        *v = tanh_lane(*v);
    }
}

macro_rules! slice_op {
    ($(#[$doc:meta])* $name:ident, $lane:ident) => {
        $(#[$doc])*
        #[inline(always)]
        pub fn $name(values: &mut [f32]) {
            let mut chunks = values.chunks_exact_mut(LANES);
            for chunk in &mut chunks {
                let mut lanes = [0f32; LANES];
                lanes.copy_from_slice(chunk);
                for v in lanes.iter_mut() {
                    *v = $lane(*v);
                }
                chunk.copy_from_slice(&lanes);
            }
            for v in chunks.into_remainder() {
                *v = $lane(*v);
            }
        }
    };
}

slice_op!(
    /// Replaces every value by its sigmoid ([`sigmoid_lane`], bit for bit).
    sigmoid_in_place,
    sigmoid_lane
);
slice_op!(
    /// Replaces every value by its `exp` ([`exp_lane`], bit for bit).
    exp_in_place,
    exp_lane
);

#[cfg(test)]
mod tests {
    use super::*;

    /// The three functions: name, slice function, scalar lane function, f64 reference.
    type Case = (&'static str, fn(&mut [f32]), fn(f32) -> f32, fn(f64) -> f64);
    const CASES: [Case; 3] = [
        ("exp", exp_in_place, exp_lane, libm::exp),
        ("sigmoid", sigmoid_in_place, sigmoid_lane, sigmoid_f64),
        ("tanh", tanh_in_place, tanh_lane, libm::tanh),
    ];

    fn sigmoid_f64(x: f64) -> f64 {
        1.0 / (1.0 + libm::exp(-x))
    }

    /// A float's position on the number line as an integer (adjacent floats differ by 1, and
    /// -0 and +0 are both 0), so that a difference of positions counts ulps.
    fn position(x: f32) -> i64 {
        let b = x.to_bits();
        let m = i64::from(b & 0x7fff_ffff);
        if b >> 31 == 1 {
            -m
        } else {
            m
        }
    }

    /// Distance in ulps of `got` from `want` (the correctly rounded f32 of the reference);
    /// NaN must give NaN (distance 0), anything else with a NaN is infinitely far.
    fn ulps(got: f32, want: f32) -> i64 {
        match (got.is_nan(), want.is_nan()) {
            (true, true) => 0,
            (false, false) => (position(got) - position(want)).abs(),
            _ => i64::MAX,
        }
    }

    /// The AVX2 and AVX-512 compilations of a slice function (run-time dispatch in `learn`
    /// uses them), where the CPU has them; `which` indexes [`CASES`].
    #[cfg(target_arch = "x86_64")]
    fn simd_variants(inputs: &[f32], which: usize) -> Vec<(&'static str, Vec<f32>)> {
        #[target_feature(enable = "avx2")]
        unsafe fn avx2(v: &mut [f32], which: usize) {
            [exp_in_place, sigmoid_in_place, tanh_in_place][which](v)
        }
        #[target_feature(enable = "avx512f")]
        unsafe fn avx512(v: &mut [f32], which: usize) {
            [exp_in_place, sigmoid_in_place, tanh_in_place][which](v)
        }
        let mut out = Vec::new();
        if std::arch::is_x86_feature_detected!("avx2") {
            let mut v = inputs.to_vec();
            // SAFETY: the CPU has AVX2.
            unsafe { avx2(&mut v, which) };
            out.push(("avx2", v));
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            let mut v = inputs.to_vec();
            // SAFETY: the CPU has AVX-512F.
            unsafe { avx512(&mut v, which) };
            out.push(("avx512", v));
        }
        out
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn simd_variants(_: &[f32], _: usize) -> Vec<(&'static str, Vec<f32>)> {
        Vec::new()
    }

    /// One value at a time through a call the compiler may not inline or vectorise.
    #[inline(never)]
    fn scalar(lane: fn(f32) -> f32, x: f32) -> f32 {
        lane(std::hint::black_box(x))
    }

    /// Checks case `which` on `inputs`: the baseline slice function, its SIMD compilations and
    /// the scalar lane function give the same bits, within 2 ulp of the f64 reference. Returns
    /// the largest distance seen and its input.
    fn check(which: usize, inputs: &[f32]) -> (i64, f32) {
        let (name, slice, lane, reference) = CASES[which];
        let mut out = inputs.to_vec();
        slice(&mut out);
        for (kernel, other) in simd_variants(inputs, which) {
            for ((x, a), b) in inputs.iter().zip(&out).zip(&other) {
                assert_eq!(
                    a.to_bits(),
                    b.to_bits(),
                    "{name}({x:e} = {:#010x}): baseline {a:e}, {kernel} {b:e}",
                    x.to_bits()
                );
            }
        }
        let mut worst = (0, 0.0);
        for (x, got) in inputs.iter().zip(&out) {
            let alone = scalar(lane, *x);
            assert_eq!(
                got.to_bits(),
                alone.to_bits(),
                "{name}({x:e}): slice {got:e}, scalar {alone:e}"
            );
            let want = reference(f64::from(*x)) as f32;
            let d = ulps(*got, want);
            assert!(
                d <= 2,
                "{name}({x:e} = {:#010x}) = {got:e}, correctly rounded {want:e}: {d} ulp",
                x.to_bits()
            );
            if d > worst.0 {
                worst = (d, *x);
            }
        }
        worst
    }

    /// A dense sweep: every 4099th bit pattern (all exponents, both signs, NaN payloads), a
    /// fine sweep of the range training sees, runs of consecutive patterns, and the edges.
    fn sweep() -> Vec<f32> {
        let mut v: Vec<f32> = (0..=u32::MAX / 4099)
            .map(|i| f32::from_bits(i * 4099))
            .collect();
        v.extend((-200_000..200_000).map(|i| i as f32 * 1e-4));
        for sign in [0u32, 0x8000_0000] {
            for start in (0x3300_0000u32..0x42d0_0000).step_by(0x1_0001) {
                v.extend((start..start + 16).map(|b| f32::from_bits(sign | b)));
            }
        }
        v.extend([
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::MAX,
            f32::MIN,
            88.72283,
            88.72284,
            -87.33655,
            -103.97208,
            -103.972084,
            TANH_POLY_BELOW,
            -TANH_POLY_BELOW,
            f32::from_bits(TANH_POLY_BELOW.to_bits() - 1),
            EXP_CLAMP_HI,
            EXP_CLAMP_LO,
        ]);
        v
    }

    #[test]
    fn activations_are_within_2_ulp_and_identical_across_kernels_on_a_dense_sweep() {
        let inputs = sweep();
        for which in 0..CASES.len() {
            check(which, &inputs);
        }
    }

    fn bits(f: fn(f32) -> f32, x: f32) -> u32 {
        f(x).to_bits()
    }

    #[test]
    fn signs_zeros_infinities_and_nan() {
        for x in [0.0f32, -0.0] {
            assert_eq!(exp_lane(x), 1.0);
            assert_eq!(sigmoid_lane(x), 0.5);
            assert_eq!(
                bits(tanh_lane, x),
                x.to_bits(),
                "tanh keeps the sign of zero"
            );
        }
        assert_eq!(exp_lane(f32::INFINITY), f32::INFINITY);
        assert_eq!(bits(exp_lane, f32::NEG_INFINITY), 0);
        assert_eq!(sigmoid_lane(f32::INFINITY), 1.0);
        assert_eq!(bits(sigmoid_lane, f32::NEG_INFINITY), 0);
        assert_eq!(tanh_lane(f32::INFINITY), 1.0);
        assert_eq!(tanh_lane(f32::NEG_INFINITY), -1.0);
        for nan in [f32::NAN, -f32::NAN, f32::from_bits(0x7f80_0001)] {
            assert!(exp_lane(nan).is_nan());
            assert!(sigmoid_lane(nan).is_nan());
            assert!(tanh_lane(nan).is_nan());
        }
        // Subnormal inputs: exp and sigmoid are 1 and 0.5 to the bit, tanh is the identity.
        for b in [1u32, 0x0040_0000, 0x007f_ffff] {
            for x in [f32::from_bits(b), -f32::from_bits(b)] {
                assert_eq!(exp_lane(x), 1.0);
                assert_eq!(sigmoid_lane(x), 0.5);
                assert_eq!(bits(tanh_lane, x), x.to_bits());
            }
        }
    }

    #[test]
    fn odd_and_monotone_where_it_matters() {
        // tanh is odd to the bit; sigmoid(-x) + sigmoid(x) is 1 within rounding.
        for x in sweep() {
            if x.is_nan() {
                continue;
            }
            assert_eq!(
                bits(tanh_lane, -x),
                bits(tanh_lane, x) ^ 0x8000_0000,
                "tanh({x:e})"
            );
            let sum = f64::from(sigmoid_lane(x)) + f64::from(sigmoid_lane(-x));
            assert!(
                (sum - 1.0).abs() <= 2e-7,
                "sigmoid({x:e}) + sigmoid(-{x:e}) = {sum}"
            );
        }
        // Non-decreasing over consecutive floats around the places where the formulas change
        // (the tanh switch at 0.55, the range-reduction steps of exp at (k + 1/2) ln 2).
        let around = |c: f32| (c.to_bits() - 5000..c.to_bits() + 5000).map(f32::from_bits);
        for c in [
            TANH_POLY_BELOW,
            0.5 * std::f32::consts::LN_2,
            1.5 * std::f32::consts::LN_2,
        ] {
            for f in [exp_lane, sigmoid_lane, tanh_lane] {
                let v: Vec<f32> = around(c).map(f).collect();
                assert!(v.windows(2).all(|w| w[0] <= w[1]), "not monotone near {c}");
            }
        }
    }

    #[test]
    fn saturating_ranges_and_subnormal_results() {
        let from = |lo: f32, hi: f32| {
            (lo.to_bits()..=hi.to_bits())
                .step_by(997)
                .map(f32::from_bits)
                .chain([hi])
        };
        // tanh(x) rounds to 1 from atanh(1 - 2^-25) = 9.01 on; sigmoid from 17.33 on.
        for x in from(9.02, f32::MAX) {
            assert_eq!(tanh_lane(x), 1.0, "tanh({x:e})");
            assert_eq!(tanh_lane(-x), -1.0, "tanh(-{x:e})");
        }
        for x in from(17.34, f32::MAX) {
            assert_eq!(sigmoid_lane(x), 1.0, "sigmoid({x:e})");
        }
        // e^x overflows from ln(f32::MAX) = 88.7228 on, and is below half the smallest
        // subnormal from -103.9721 down.
        for x in from(88.722_84, f32::MAX) {
            assert_eq!(exp_lane(x), f32::INFINITY, "exp({x:e})");
        }
        assert!(exp_lane(88.722_83) < f32::INFINITY);
        for x in from(103.972_09, f32::MAX) {
            assert_eq!(bits(exp_lane, -x), 0, "exp(-{x:e})");
            assert_eq!(bits(sigmoid_lane, -x), 0, "sigmoid(-{x:e})");
        }
        // Between -103.97 and -87.34 the results are subnormal, not flushed to zero, and
        // within 1 ulp (2^-149) of the reference.
        for x in from(87.34, 103.97) {
            for (f, reference) in [
                (exp_lane as fn(f32) -> f32, CASES[0].3),
                (sigmoid_lane, CASES[1].3),
            ] {
                let got = f(-x);
                let want = reference(-f64::from(x)) as f32;
                assert!(got > 0.0 && got < f32::MIN_POSITIVE, "{got:e} at -{x:e}");
                assert!(ulps(got, want) <= 1, "{got:e} vs {want:e} at -{x:e}");
            }
        }
    }

    /// All 2^32 inputs of each function (baseline, AVX2 and AVX-512 compilations, scalar) against
    /// the f64 reference; run in release with `SWARMFL_EXHAUSTIVE=1` (a few minutes on two
    /// threads). Without the variable it checks every 65537th pattern instead.
    #[test]
    fn activations_within_2_ulp_exhaustively_when_asked() {
        let step: u64 = if std::env::var_os("SWARMFL_EXHAUSTIVE").is_some() {
            1
        } else {
            65_537
        };
        let threads: u64 = 2;
        for (which, case) in CASES.iter().enumerate() {
            let per = (1u64 << 32).div_ceil(threads);
            let results: Vec<(u64, i64, f32)> = std::thread::scope(|scope| {
                let handles: Vec<_> = (0..threads)
                    .map(|t| {
                        scope.spawn(move || {
                            let (mut b, end) = (t * per, ((t + 1) * per).min(1 << 32));
                            // Each thread starts on the step grid of the whole range.
                            b = b.div_ceil(step) * step;
                            let (mut checked, mut worst) = (0u64, (0i64, 0f32));
                            let mut inputs = Vec::with_capacity(1 << 16);
                            while b < end {
                                inputs.clear();
                                while inputs.len() < (1 << 16) && b < end {
                                    inputs.push(f32::from_bits(b as u32));
                                    b += step;
                                }
                                checked += inputs.len() as u64;
                                let w = check(which, &inputs);
                                if w.0 > worst.0 {
                                    worst = w;
                                }
                            }
                            (checked, worst.0, worst.1)
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .map(|h| h.join().expect("no panic"))
                    .collect()
            });
            let checked: u64 = results.iter().map(|r| r.0).sum();
            let worst = results.iter().max_by_key(|r| r.1).expect("two threads");
            eprintln!(
                "{}: {checked} inputs within 2 ulp, identical across kernels; largest {} ulp (at {:e})",
                case.0, worst.1, worst.2
            );
        }
    }
}

//! Lane-wise, bit-exact ports of the `libm` crate's `expf`, `expm1f` and `tanhf`.
//!
//! The training kernels evaluate thousands of activations per time step. Calling `libm` once per
//! value is correct but slow (branches, no SIMD). The functions here run the very same sequence
//! of IEEE operations as `libm` 0.2 (FreeBSD msun), but branch-free over a chunk of [`LANES`]
//! values: every lane computes every candidate result and the lane's case selects one. Each
//! operation is a single correctly rounded IEEE operation, so the result is bit-identical to
//! `libm` for every input; the tests check a dense sweep, and `SWARMFL_EXHAUSTIVE=1 cargo test
//! --release -p swarmfl-core exhaustive` checks all 2^32 inputs.
//!
//! No fused multiply-add is used (Rust never contracts `a * b + c`), and no operation is
//! reassociated.

/// Width of the chunks the lane-wise functions process (one AVX-512 vector, two AVX2 vectors);
/// any slice length is accepted (the tail runs lane by lane through the same code).
pub const LANES: usize = 16;

const EXP_LN2_HI: f32 = f32::from_bits(0x3f317200);
const EXP_LN2_LO: f32 = f32::from_bits(0x35bfbe8e);
const INV_LN2: f32 = f32::from_bits(0x3fb8aa3b);
const EXP_P1: f32 = f32::from_bits(0x3e2aaa8f);
const EXP_P2: f32 = f32::from_bits(0xbb355215);

const EXPM1_LN2_HI: f32 = f32::from_bits(0x3f317180);
const EXPM1_LN2_LO: f32 = f32::from_bits(0x3717f7d1);
const EXPM1_Q1: f32 = f32::from_bits(0xbd088868);
const EXPM1_Q2: f32 = f32::from_bits(0x3acf3010);

#[inline(always)]
fn pow2(k: i32) -> f32 {
    // 2^k for k in [-126, 127]; callers clamp k first so the shift never overflows.
    f32::from_bits(((0x7f + k) as u32) << 23)
}

/// `libm::expf` of one value, written branch-free so that a loop over lanes vectorises.
#[inline(always)]
pub fn expf_lane(x_in: f32) -> f32 {
    let bits = x_in.to_bits();
    let sign = (bits >> 31) as i32;
    let hx = bits & 0x7fff_ffff;

    // Argument reduction, as libm: k from the rounded quotient for |x| > 1.5 ln2, +-1 between
    // 0.5 ln2 and 1.5 ln2, 0 below. The float-to-int cast runs on a clamped value so that lanes
    // whose result is discarded (NaN, huge) stay well defined; valid lanes are never clamped.
    let half = if sign != 0 { -0.5f32 } else { 0.5f32 };
    let q = (INV_LN2 * x_in + half).clamp(-256.0, 256.0);
    let q = if q.is_nan() { 0.0 } else { q };
    // SAFETY: q is finite and within [-256, 256], so the truncation fits an i32. (A plain `as`
    // would saturate, which LLVM does not vectorise.)
    let k_far: i32 = unsafe { q.to_int_unchecked() };
    let k = if hx > 0x3f85_1592 {
        k_far
    } else if hx > 0x3eb1_7218 {
        1 - sign - sign
    } else {
        0
    };
    let kf = k as f32;
    // For k = 0 these give hi = x, lo = 0, x = x exactly, which is libm's middle branch.
    let hi = x_in - kf * EXP_LN2_HI;
    let lo = kf * EXP_LN2_LO;
    let x = hi - lo;

    let xx = x * x;
    let c = x - xx * (EXP_P1 + xx * EXP_P2);
    let y = 1. + (x * c / (2. - c) - lo + hi);

    // scalbnf(y, k): y is in [0.5, 2), k in [-150, 128]. libm prescales so that only the last
    // multiplication rounds; the same split here (exact prescale, one rounding multiply).
    let kc = k.clamp(-160, 160);
    let (pre, rest) = if kc > 127 {
        (f32::from_bits(0x7f00_0000), kc - 127)
    } else if kc < -126 {
        (
            f32::from_bits(0x0080_0000) * f32::from_bits(0x4b80_0000),
            kc + 102,
        )
    } else {
        (1.0f32, kc)
    };
    let rest = rest.clamp(-126, 127);
    let scaled = y * pre * pow2(rest);
    let main = if k == 0 { y } else { scaled };

    let tiny = 1. + x_in;
    let overflow = x_in * f32::from_bits(0x7f00_0000);
    let mut r = main;
    if hx <= 0x3900_0000 {
        r = tiny;
    }
    if sign != 0 && hx >= 0x42cf_f1b5 {
        r = 0.0;
    }
    if sign == 0 && hx >= 0x42b1_7218 {
        r = overflow;
    }
    if hx > 0x7f80_0000 {
        r = x_in;
    }
    r
}

/// `libm::expf` for arguments with 2^-13 < |x| < 87 only, where none of libm's special cases
/// (tiny, overflow, underflow, NaN) applies and the scale factor 2^k is a normal number: the
/// same IEEE operations as [`expf_lane`] takes for those arguments, without computing the
/// candidates it would discard (`y * 1.0` is exact, so `y * 2^k` is its result for every k),
/// and without clamps: k is within [-126, 126].
///
/// # Safety
/// `x_in` is in that range ([`all_expf_normal`]); outside it a float-to-int conversion could
/// be out of range.
#[inline(always)]
unsafe fn expf_normal(x_in: f32) -> f32 {
    let bits = x_in.to_bits();
    let sign = (bits >> 31) as i32;
    let hx = bits & 0x7fff_ffff;
    let half = if sign != 0 { -0.5f32 } else { 0.5f32 };
    let q = INV_LN2 * x_in + half;
    // SAFETY: |x_in| < 87 (the caller's contract), so q is finite and |q| < 127.
    let k_far: i32 = unsafe { q.to_int_unchecked() };
    let k = if hx > 0x3f85_1592 {
        k_far
    } else if hx > 0x3eb1_7218 {
        1 - sign - sign
    } else {
        0
    };
    let kf = k as f32;
    let hi = x_in - kf * EXP_LN2_HI;
    let lo = kf * EXP_LN2_LO;
    let x = hi - lo;
    let xx = x * x;
    let c = x - xx * (EXP_P1 + xx * EXP_P2);
    let y = 1. + (x * c / (2. - c) - lo + hi);
    y * pow2(k)
}

/// True if every value of the chunk is an argument [`expf_normal`] handles (as `x` or `-x`).
#[inline(always)]
fn all_expf_normal(values: &[f32; LANES]) -> bool {
    values.iter().fold(true, |ok, v| {
        let hx = v.to_bits() & 0x7fff_ffff;
        ok & (hx > 0x3900_0000) & (hx < 0x42ae_0000)
    })
}

/// `libm::expm1f` of one value, written branch-free.
#[inline(always)]
pub fn expm1f_lane(x_in: f32) -> f32 {
    let x1p127 = f32::from_bits(0x7f00_0000);
    let bits = x_in.to_bits();
    let sign = (bits >> 31) != 0;
    let hx = bits & 0x7fff_ffff;

    let half = if sign { -0.5f32 } else { 0.5f32 };
    let q = (INV_LN2 * x_in + half).clamp(-256.0, 256.0);
    let q = if q.is_nan() { 0.0 } else { q };
    // SAFETY: q is finite and within [-256, 256], so the truncation fits an i32. (A plain `as`
    // would saturate, which LLVM does not vectorise.)
    let k_far: i32 = unsafe { q.to_int_unchecked() };
    let reduce = hx > 0x3eb1_7218;
    let k = if reduce {
        if hx < 0x3f85_1592 {
            if sign {
                -1
            } else {
                1
            }
        } else {
            k_far
        }
    } else {
        0
    };
    // libm's +-1 branch computes x -+ LN2_HI and +-LN2_LO directly; t * LN2_HI with t = +-1 is
    // exact, so the general formula gives the same bits. For k = 0: hi = x, lo = 0, c = 0.
    let t = k as f32;
    let hi = x_in - t * EXPM1_LN2_HI;
    let lo = t * EXPM1_LN2_LO;
    let x = if reduce { hi - lo } else { x_in };
    let c = if reduce { (hi - x) - lo } else { 0.0 };

    let hfx = 0.5 * x;
    let hxs = x * hfx;
    let r1 = 1. + hxs * (EXPM1_Q1 + hxs * EXPM1_Q2);
    let tt = 3. - r1 * hfx;
    let e0 = hxs * ((r1 - tt) / (6. - x * tt));
    let res_k0 = x - (x * e0 - hxs);
    let e = x * (e0 - c) - c;
    let e = e - hxs;
    let res_km1 = 0.5 * (x - e) - 0.5;
    let res_k1 = if x < -0.25 {
        -2. * (e - (x + 0.5))
    } else {
        1. + 2. * (x - e)
    };
    let kc = k.clamp(-126, 127);
    let twopk = pow2(kc);
    let ufk = (-kc).clamp(-126, 127);
    let uf = pow2(ufk);
    let res_mid = if k < 23 {
        (x - e + (1. - uf)) * twopk
    } else {
        (x - (e + uf) + 1.) * twopk
    };
    let y = x - e + 1.;
    let y = if k == 128 { y * 2. * x1p127 } else { y * twopk };
    let res_far = y - 1.;

    let mut r = if k == 0 {
        res_k0
    } else if k == -1 {
        res_km1
    } else if k == 1 {
        res_k1
    } else if (0..=56).contains(&k) {
        res_mid
    } else {
        res_far
    };
    if hx < 0x3300_0000 {
        r = x_in;
    }
    if hx >= 0x4195_b844 {
        if sign {
            r = -1.;
        } else if hx > 0x42b1_7217 {
            r = x_in * x1p127;
        }
        if hx > 0x7f80_0000 {
            r = x_in;
        }
    }
    r
}

/// `libm::expm1f` restricted to the arguments `tanhf` passes it: x in [-0.55, 20.5] (k in
/// [-1, 30]), where libm's special cases (|x| >= 27 ln2 with x < 0, overflow, NaN) and its
/// far branch (k < -1 or k > 56) cannot occur. Outside that range the result is unspecified
/// (but never undefined behaviour); `tanhf_lane` discards those lanes.
#[inline(always)]
fn expm1f_for_tanh(x_in: f32) -> f32 {
    let bits = x_in.to_bits();
    let sign = (bits >> 31) != 0;
    let hx = bits & 0x7fff_ffff;
    let half = if sign { -0.5f32 } else { 0.5f32 };
    let q = (INV_LN2 * x_in + half).clamp(-64.0, 64.0);
    let q = if q.is_nan() { 0.0 } else { q };
    // SAFETY: q is finite and within [-64, 64].
    let k_far: i32 = unsafe { q.to_int_unchecked() };
    let reduce = hx > 0x3eb1_7218;
    let k = if !reduce {
        0
    } else if hx < 0x3f85_1592 {
        if sign {
            -1
        } else {
            1
        }
    } else {
        k_far
    };
    let t = k as f32;
    let hi = x_in - t * EXPM1_LN2_HI;
    let lo = t * EXPM1_LN2_LO;
    let x = if reduce { hi - lo } else { x_in };
    let c = if reduce { (hi - x) - lo } else { 0.0 };

    let hfx = 0.5 * x;
    let hxs = x * hfx;
    let r1 = 1. + hxs * (EXPM1_Q1 + hxs * EXPM1_Q2);
    let tt = 3. - r1 * hfx;
    let e0 = hxs * ((r1 - tt) / (6. - x * tt));
    let res_k0 = x - (x * e0 - hxs);
    let e = x * (e0 - c) - c;
    let e = e - hxs;
    let res_km1 = 0.5 * (x - e) - 0.5;
    let res_k1 = if x < -0.25 {
        -2. * (e - (x + 0.5))
    } else {
        1. + 2. * (x - e)
    };
    let kc = k.clamp(-64, 64);
    let twopk = pow2(kc);
    let uf = pow2(-kc);
    let res_mid = if k < 23 {
        (x - e + (1. - uf)) * twopk
    } else {
        (x - (e + uf) + 1.) * twopk
    };
    let r = if k == 0 {
        res_k0
    } else if k == -1 {
        res_km1
    } else if k == 1 {
        res_k1
    } else {
        res_mid
    };
    if hx < 0x3300_0000 {
        x_in
    } else {
        r
    }
}

/// `2 / (t + 2)` if `two`, else `t / (t + 2)`, with one division. The dividend is chosen by
/// masking bits rather than by `if`: LLVM turns a selected dividend into two divisions and a
/// selected quotient (seen in the AVX-512 code: three divisions per `tanh` instead of two), and
/// division is the slowest operation here.
#[inline(always)]
fn one_quotient(two: bool, t: f32) -> f32 {
    let m = u32::from(two).wrapping_neg();
    let dividend = f32::from_bits((t.to_bits() & !m) | (2f32.to_bits() & m));
    dividend / (t + 2.)
}

/// `libm::tanhf` for 2^-25 <= |x| <= 7.5 only (`w` in [0x3300_0000, 0x40f0_0000]), where
/// tanh takes none of libm's edge cases (tiny, |x| > 10, NaN) and `expm1f` gets arguments in
/// [-0.52, 15]: k in [-1, 21], so neither its k >= 23 form nor its clamps and special cases
/// can apply, and its k = 1 form always has x >= -0.25 (the argument is then 2|x| > 0.51, so
/// the reduced x is above 0.51 - ln 2). The same IEEE operations as [`tanhf_lane`] takes for
/// these arguments, without the candidates it would discard. Checked on all of its inputs by
/// the exhaustive test. It repeats steps of [`expm1f_for_tanh`] rather than sharing helper
/// functions with it: with the shared steps factored out (k, the reduced candidates, the pick
/// by k), one-thread training was measurably slower (docs/PERFORMANCE.md, "Notes from the
/// code").
///
/// # Safety
/// `x_in` is in that range ([`all_tanh_mid`]); outside it a float-to-int conversion could be
/// out of range.
#[inline(always)]
unsafe fn tanhf_mid(x_in: f32) -> f32 {
    let bits = x_in.to_bits();
    let sign = (bits >> 31) != 0;
    let w = bits & 0x7fff_ffff;
    let ax = f32::from_bits(w);
    let upper = w > 0x3e82_c578;
    let arg = if upper { 2. * ax } else { -2. * ax };
    // expm1f(arg), as `expm1f_for_tanh`.
    let hx = arg.to_bits() & 0x7fff_ffff;
    let half = if upper { 0.5f32 } else { -0.5f32 };
    let q = INV_LN2 * arg + half;
    // SAFETY: |arg| <= 15 (the caller's contract), so q is finite and |q| < 23.
    let k_far: i32 = unsafe { q.to_int_unchecked() };
    let reduce = hx > 0x3eb1_7218;
    let k = if !reduce {
        0
    } else if hx < 0x3f85_1592 {
        if upper {
            1
        } else {
            -1
        }
    } else {
        k_far
    };
    // For k = 0: hi = arg, lo = 0, x = arg and c = 0 exactly, libm's unreduced case.
    let t = k as f32;
    let hi = arg - t * EXPM1_LN2_HI;
    let lo = t * EXPM1_LN2_LO;
    let x = hi - lo;
    let c = (hi - x) - lo;
    let hfx = 0.5 * x;
    let hxs = x * hfx;
    let r1 = 1. + hxs * (EXPM1_Q1 + hxs * EXPM1_Q2);
    let tt = 3. - r1 * hfx;
    let e0 = hxs * ((r1 - tt) / (6. - x * tt));
    let res_k0 = x - (x * e0 - hxs);
    let e = x * (e0 - c) - c;
    let e = e - hxs;
    let res_km1 = 0.5 * (x - e) - 0.5;
    let res_k1 = 1. + 2. * (x - e);
    // libm's 2 <= k < 23 form (2^-k and 2^k); k is at most 21 here. The clamp only keeps the
    // lanes that discard this candidate (k < 2) from shifting a negative exponent.
    let kc = k.clamp(0, 64);
    let res_mid = (x - e + (1. - pow2(-kc))) * pow2(kc);
    let em1 = if k == 0 {
        res_k0
    } else if k == -1 {
        res_km1
    } else if k == 1 {
        res_k1
    } else {
        res_mid
    };
    let quotient = one_quotient(w > 0x3f0c_9f54, em1);
    let r = if w > 0x3f0c_9f54 {
        1. - quotient
    } else if upper {
        quotient
    } else {
        -quotient
    };
    if sign {
        -r
    } else {
        r
    }
}

/// True if every value of the chunk is an argument [`tanhf_mid`] handles.
#[inline(always)]
fn all_tanh_mid(values: &[f32; LANES]) -> bool {
    values.iter().fold(true, |ok, v| {
        let w = v.to_bits() & 0x7fff_ffff;
        ok & (0x3300_0000..=0x40f0_0000).contains(&w)
    })
}

/// `libm::tanhf` of one value, written branch-free.
#[inline(always)]
pub fn tanhf_lane(x_in: f32) -> f32 {
    let bits = x_in.to_bits();
    let sign = (bits >> 31) != 0;
    let w = bits & 0x7fff_ffff;
    let x = f32::from_bits(w);

    let arg = if w > 0x3e82_c578 { 2. * x } else { -2. * x };
    let t = expm1f_for_tanh(arg);
    // libm's 1 + 0 / x for |x| > 10 is 1, or x's NaN quieted (as 1 + x gives it): no division.
    let big = if x.is_nan() { x + 1. } else { 1. };
    // libm's middle branch is 1 - 2 / (t + 2), its lower branch -t / (t + 2); negating the
    // dividend negates a correctly rounded quotient exactly, so that is -(t / (t + 2)). A lane
    // needs only one of the quotients: one division with the lane's dividend serves all three.
    let quotient = one_quotient(w > 0x3f0c_9f54, t);
    let tt = if w > 0x4120_0000 {
        big
    } else if w > 0x3f0c_9f54 {
        1. - quotient
    } else if w > 0x3e82_c578 {
        quotient
    } else if w >= 0x0080_0000 {
        -quotient
    } else {
        x
    };
    if sign {
        -tt
    } else {
        tt
    }
}

/// The logistic sigmoid 1 / (1 + expf(-x)) with `libm`'s `expf` (bit-exact lane-wise port).
#[inline(always)]
pub fn sigmoid_lane(x: f32) -> f32 {
    1.0 / (1.0 + expf_lane(-x))
}

/// The scalar reference of [`sigmoid_lane`], built on `libm` itself.
pub fn sigmoid_libm(x: f32) -> f32 {
    1.0 / (1.0 + libm::expf(-x))
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

/// [`sigmoid_lane`] through [`expf_normal`].
///
/// # Safety
/// As [`expf_normal`]: 2^-13 < |x| < 87.
#[inline(always)]
unsafe fn sigmoid_normal(x: f32) -> f32 {
    // SAFETY: -x is in range when x is (the caller's contract).
    1.0 / (1.0 + unsafe { expf_normal(-x) })
}

/// A slice function like [`slice_op!`]'s, whose chunks of [`LANES`] values take the unsafe
/// fast lane function when the check accepts the whole chunk, and the full port otherwise (one
/// function per chunk, so a chunk's lanes run the same operations and vectorise). A macro, not
/// a function taking closures: the closures were not inlined into the AVX2 compilation, and
/// its training ran far slower (docs/PERFORMANCE.md, "Notes from the code").
macro_rules! slice_op_with_fast_path {
    ($(#[$doc:meta])* $name:ident, $fits:ident, $fast:ident, $full:ident) => {
        $(#[$doc])*
        #[inline(always)]
        pub fn $name(values: &mut [f32]) {
            let mut chunks = values.chunks_exact_mut(LANES);
            for chunk in &mut chunks {
                let mut lanes = [0f32; LANES];
                lanes.copy_from_slice(chunk);
                if $fits(&lanes) {
                    for v in lanes.iter_mut() {
                        // SAFETY: the check accepted every lane of the chunk.
                        *v = unsafe { $fast(*v) };
                    }
                } else {
                    for v in lanes.iter_mut() {
                        *v = $full(*v);
                    }
                }
                chunk.copy_from_slice(&lanes);
            }
            for v in chunks.into_remainder() {
                *v = $full(*v);
            }
        }
    };
}

slice_op_with_fast_path!(
    /// Replaces every value by its sigmoid (bit-identical to [`sigmoid_libm`]). Chunks whose
    /// values all lie in 2^-13 < |x| < 87 (nearly all of them in training) take
    /// a special-case-free `expf` (`expf_normal`); the rest take the full port.
    sigmoid_in_place,
    all_expf_normal,
    sigmoid_normal,
    sigmoid_lane
);
slice_op_with_fast_path!(
    /// Replaces every value by its `tanhf` (bit-identical to `libm::tanhf`). Chunks whose
    /// values all lie in 2^-25 <= |x| <= 7.5 (nearly all of them in training) take
    /// a `tanhf` without libm's edge cases (`tanhf_mid`); the rest take the full port.
    tanh_in_place,
    all_tanh_mid,
    tanhf_mid,
    tanhf_lane
);
slice_op!(
    /// Replaces every value by its `expf` (bit-identical to `libm::expf`).
    exp_in_place,
    expf_lane
);
slice_op!(
    /// Replaces every value by its `expm1f` (bit-identical to `libm::expm1f`).
    expm1_in_place,
    expm1f_lane
);

#[cfg(test)]
mod tests {
    use super::*;

    /// Compares a lane-wise slice function with its scalar `libm` reference on `inputs`.
    fn check(name: &str, lanes: fn(&mut [f32]), reference: fn(f32) -> f32, inputs: &[f32]) {
        let mut out = inputs.to_vec();
        lanes(&mut out);
        for (x, got) in inputs.iter().zip(&out) {
            let want = reference(*x);
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "{name}({x:e} = {:#010x}): lane-wise {got:e}, libm {want:e}",
                x.to_bits()
            );
        }
    }

    /// A dense sweep: every 4099th bit pattern (all exponents, both signs, NaN payloads), plus a
    /// fine sweep of the range the LSTM actually sees.
    fn sweep() -> Vec<f32> {
        let mut v: Vec<f32> = (0..=u32::MAX / 4099)
            .map(|i| f32::from_bits(i * 4099))
            .collect();
        v.extend((-200_000..200_000).map(|i| i as f32 * 1e-4));
        // Runs of consecutive bit patterns across the whole range of the `tanh` and sigmoid
        // fast paths (chunks of 16 that lie entirely inside it), both signs.
        for sign in [0u32, 0x8000_0000] {
            for start in (0x3300_0000u32..0x42b0_0000).step_by(0x1_0001) {
                v.extend((start..start + 16).map(|b| f32::from_bits(sign | b)));
            }
        }
        v.extend([
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
            88.72283,
            88.72284,
            -87.33655,
            -103.97208,
            -103.972084,
            10.0,
            -10.0,
            f32::from_bits(0x3f85_1592),
            f32::from_bits(0x3eb1_7218),
            f32::from_bits(0x3900_0000),
            f32::from_bits(0x3f0c_9f54),
            f32::from_bits(0x3e82_c578),
            f32::from_bits(0x4195_b844),
        ]);
        v
    }

    #[test]
    fn lane_ports_match_libm_on_a_dense_sweep() {
        let inputs = sweep();
        check("expf", exp_in_place, libm::expf, &inputs);
        check("expm1f", expm1_in_place, libm::expm1f, &inputs);
        check("tanhf", tanh_in_place, libm::tanhf, &inputs);
        check("sigmoid", sigmoid_in_place, sigmoid_libm, &inputs);
    }

    /// The same sweep through the AVX2 and AVX-512 compilations of the ports (run-time
    /// dispatch in `learn` uses them), where the CPU has them.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_compilations_of_the_ports_match_libm() {
        #[target_feature(enable = "avx2")]
        unsafe fn all_avx2(v: &mut [f32], which: usize) {
            [
                exp_in_place,
                expm1_in_place,
                tanh_in_place,
                sigmoid_in_place,
            ][which](v)
        }
        #[target_feature(enable = "avx512f")]
        unsafe fn all_avx512(v: &mut [f32], which: usize) {
            [
                exp_in_place,
                expm1_in_place,
                tanh_in_place,
                sigmoid_in_place,
            ][which](v)
        }
        let inputs = sweep();
        let refs: [fn(f32) -> f32; 4] = [libm::expf, libm::expm1f, libm::tanhf, sigmoid_libm];
        for (which, reference) in refs.iter().enumerate() {
            let mut variants = Vec::new();
            if std::arch::is_x86_feature_detected!("avx2") {
                let mut v = inputs.clone();
                // SAFETY: the CPU has AVX2.
                unsafe { all_avx2(&mut v, which) };
                variants.push(("avx2", v));
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                let mut v = inputs.clone();
                // SAFETY: the CPU has AVX-512F.
                unsafe { all_avx512(&mut v, which) };
                variants.push(("avx512", v));
            }
            for (name, out) in variants {
                for (x, got) in inputs.iter().zip(&out) {
                    let want = reference(*x);
                    assert_eq!(
                        got.to_bits(),
                        want.to_bits(),
                        "{name} function {which} at {x:e}"
                    );
                }
            }
        }
    }

    /// All 2^32 inputs; run in release with `SWARMFL_EXHAUSTIVE=1` (about a minute per
    /// function). Without the variable it checks every 65537th pattern instead.
    #[test]
    fn lane_ports_match_libm_exhaustively_when_asked() {
        let step: u64 = if std::env::var_os("SWARMFL_EXHAUSTIVE").is_some() {
            1
        } else {
            65_537
        };
        type Pair = (&'static str, fn(&mut [f32]), fn(f32) -> f32);
        let pairs: [Pair; 4] = [
            ("expf", exp_in_place, libm::expf),
            ("expm1f", expm1_in_place, libm::expm1f),
            ("tanhf", tanh_in_place, libm::tanhf),
            ("sigmoid", sigmoid_in_place, sigmoid_libm),
        ];
        for (name, lanes, reference) in pairs {
            let mut start: u64 = 0;
            let mut checked: u64 = 0;
            let mut inputs = Vec::with_capacity(1 << 16);
            while start <= u32::MAX as u64 {
                inputs.clear();
                let mut b = start;
                while inputs.len() < (1 << 16) && b <= u32::MAX as u64 {
                    inputs.push(f32::from_bits(b as u32));
                    b += step;
                }
                start = b;
                checked += inputs.len() as u64;
                check(name, lanes, reference, &inputs);
            }
            eprintln!("{name}: {checked} inputs bit-identical to libm");
        }
    }
}

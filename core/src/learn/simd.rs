//! Explicit-SIMD versions of the two matrix kernels ([`super::kernels::rows_acc`] and
//! [`super::kernels::outer_acc`]) for AVX-512 and AVX2, written with `core::arch` intrinsics.
//!
//! Register blocking decides which sums run side by side, never the order of the terms within
//! a sum: every lane of every accumulator is updated as `acc = acc + x * m` (one IEEE multiply,
//! rounded, then one IEEE add; never a fused multiply-add), with the terms in the same order as
//! the portable code, so the bits are the same. What blocking buys is independent dependency
//! chains: one sample's back-propagated hidden gradient is a single chain of 64 dependent adds
//! per lane, which the portable code cannot overlap; here 4 to 8 samples' chains advance together,
//! and each weight row (or gradient row) is loaded once per tile instead of once per sample.
//!
//! Lanes that do not fill a vector (model sizes whose widths are not multiples of the vector
//! width) run through scalar code with the same order of terms.

#![cfg(target_arch = "x86_64")]
// Index loops read several arrays at the same position; iterators would hide that.
#![allow(clippy::needless_range_loop)]
// Every function here is an `unsafe fn` made of intrinsics of one instruction set; its safety
// contract (the CPU has that set) is the function's own, so the bodies are not re-wrapped.
#![allow(unsafe_op_in_unsafe_fn)]

use std::arch::x86_64::*;

use super::kernels::Mat;

/// One SIMD vector of `f32` lanes and the five operations the kernels use.
///
/// # Safety
/// Every method requires the CPU feature of the implementing type (checked by the caller).
trait Vector: Copy {
    /// Lanes per vector.
    const W: usize;
    unsafe fn zero() -> Self;
    /// Loads `W` values from `src` (unaligned); `src..src + W` must be in bounds.
    unsafe fn load_ptr(src: *const f32) -> Self;
    /// Stores the lanes at `dst` (unaligned); `dst..dst + W` must be in bounds.
    unsafe fn store_ptr(self, dst: *mut f32);
    unsafe fn splat(x: f32) -> Self;
    /// `self + x * m`, lane-wise: a rounded multiply, then a rounded add.
    unsafe fn mul_then_add(self, x: Self, m: Self) -> Self;
    /// `self + other`, lane-wise.
    unsafe fn add(self, other: Self) -> Self;
}

impl Vector for __m512 {
    const W: usize = 16;
    #[inline(always)]
    unsafe fn zero() -> Self {
        _mm512_setzero_ps()
    }
    #[inline(always)]
    unsafe fn load_ptr(src: *const f32) -> Self {
        _mm512_loadu_ps(src)
    }
    #[inline(always)]
    unsafe fn store_ptr(self, dst: *mut f32) {
        _mm512_storeu_ps(dst, self)
    }
    #[inline(always)]
    unsafe fn splat(x: f32) -> Self {
        _mm512_set1_ps(x)
    }
    #[inline(always)]
    unsafe fn mul_then_add(self, x: Self, m: Self) -> Self {
        _mm512_add_ps(self, _mm512_mul_ps(x, m))
    }
    #[inline(always)]
    unsafe fn add(self, other: Self) -> Self {
        _mm512_add_ps(self, other)
    }
}

impl Vector for __m256 {
    const W: usize = 8;
    #[inline(always)]
    unsafe fn zero() -> Self {
        _mm256_setzero_ps()
    }
    #[inline(always)]
    unsafe fn load_ptr(src: *const f32) -> Self {
        _mm256_loadu_ps(src)
    }
    #[inline(always)]
    unsafe fn store_ptr(self, dst: *mut f32) {
        _mm256_storeu_ps(dst, self)
    }
    #[inline(always)]
    unsafe fn splat(x: f32) -> Self {
        _mm256_set1_ps(x)
    }
    #[inline(always)]
    unsafe fn mul_then_add(self, x: Self, m: Self) -> Self {
        _mm256_add_ps(self, _mm256_mul_ps(x, m))
    }
    #[inline(always)]
    unsafe fn add(self, other: Self) -> Self {
        _mm256_add_ps(self, other)
    }
}

/// `out[s][j] += sum over kk ascending of a[s][kk] m[kk][j]` for samples `s0..s0 + S` and lanes
/// `j0..j0 + B * W`; `out` is `samples x n`, `a` is `samples x k`, `m` is `k x n`. With `ZERO`
/// the sums start from +0 instead of `out` (the bits of `out` filled with +0 first, without
/// the fill and the loads).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn rows_tile<V: Vector, const S: usize, const B: usize, const ZERO: bool>(
    out: &mut [f32],
    a: &[f32],
    m: &[f32],
    n: usize,
    k: usize,
    s0: usize,
    j0: usize,
) {
    // The tile's extents, checked once; the loops below then index by pointer, without a
    // bounds check per term (the checks cost as much as the arithmetic in the 8 x 16 tile).
    assert!(
        (s0 + S) * n <= out.len()
            && (s0 + S) * k <= a.len()
            && j0 + B * V::W <= n
            && k * n <= m.len(),
        "rows tile out of bounds"
    );
    let (out_p, a_p, m_p) = (out.as_mut_ptr(), a.as_ptr(), m.as_ptr());
    let mut acc = [[V::zero(); B]; S];
    if !ZERO {
        for s in 0..S {
            for b in 0..B {
                acc[s][b] = V::load_ptr(out_p.add((s0 + s) * n + j0 + b * V::W));
            }
        }
    }
    for kk in 0..k {
        let row = m_p.add(kk * n + j0);
        let mut r = [V::zero(); B];
        for b in 0..B {
            r[b] = V::load_ptr(row.add(b * V::W));
        }
        for s in 0..S {
            let x = V::splat(*a_p.add((s0 + s) * k + kk));
            for b in 0..B {
                acc[s][b] = acc[s][b].mul_then_add(x, r[b]);
            }
        }
    }
    for s in 0..S {
        for b in 0..B {
            acc[s][b].store_ptr(out_p.add((s0 + s) * n + j0 + b * V::W));
        }
    }
}

/// One pass of [`rows_tile`] over the lanes `j0..`: as many blocks of `B * W` lanes as fit,
/// samples in tiles of `S` (the remainder one by one); returns the first lane not covered.
#[inline(always)]
unsafe fn rows_pass<V: Vector, const S: usize, const B: usize, const ZERO: bool>(
    out: &mut [f32],
    a: &[f32],
    m: &[f32],
    n: usize,
    mut j0: usize,
) -> usize {
    let (samples, k) = (out.len() / n, m.len() / n);
    while j0 + B * V::W <= n {
        let mut s0 = 0;
        while s0 + S <= samples {
            rows_tile::<V, S, B, ZERO>(out, a, m, n, k, s0, j0);
            s0 += S;
        }
        while s0 < samples {
            rows_tile::<V, 1, B, ZERO>(out, a, m, n, k, s0, j0);
            s0 += 1;
        }
        j0 += B * V::W;
    }
    j0
}

/// The lanes `j0..n` of [`super::kernels::rows_acc`], one scalar at a time (same order), from
/// +0 with `zero`.
#[inline(always)]
fn rows_scalar_tail(out: &mut [f32], a: &[f32], m: &[f32], n: usize, j0: usize, zero: bool) {
    let (samples, k) = (out.len() / n, m.len() / n);
    for s in 0..samples {
        for j in j0..n {
            let mut acc = if zero { 0.0 } else { out[s * n + j] };
            for kk in 0..k {
                acc += a[s * k + kk] * m[kk * n + j];
            }
            out[s * n + j] = acc;
        }
    }
}

/// Checks the sizes of a `rows_acc` call (a bad size is a bug, never input).
#[inline(always)]
fn rows_check(out: &[f32], a: &[f32], m: &[f32], n: usize) {
    let samples = out.len() / n;
    let k = m.len() / n;
    assert!(
        out.len() == samples * n && a.len() == samples * k && m.len() == k * n,
        "rows_acc: {samples} x {n} output, {} inputs, {} matrix entries",
        a.len(),
        m.len()
    );
}

/// Sizes of an `outer_acc` call, as [`super::kernels::outer_acc`] takes them.
struct Outer {
    steps: usize,
    group: usize,
    rows: usize,
    n: usize,
}

/// For sample `s`, rows `r0..r0 + R`, lanes `j0..j0 + B * W`: the partial sum over time steps
/// `P[r][j] = 0 + a[0][s][r] d[0][s][j] + ... + a[T-1][s][r] d[T-1][s][j]`, then
/// `grad[r][j] += P[r][j]`.
#[inline(always)]
unsafe fn outer_tile<V: Vector, const R: usize, const B: usize>(
    grad: &mut [f32],
    a: &[f32],
    d: &[f32],
    o: &Outer,
    s: usize,
    r0: usize,
    j0: usize,
) {
    // The tile's extents, checked once (the last step's rows and lanes are the furthest).
    assert!(o.steps >= 1, "outer tile of no step");
    let last = (o.steps - 1) * o.group + s;
    assert!(
        last * o.rows + r0 + R <= a.len()
            && last * o.n + j0 + B * V::W <= d.len()
            && r0 + R <= o.rows
            && j0 + B * V::W <= o.n
            && (r0 + R) * o.n <= grad.len(),
        "outer tile out of bounds"
    );
    let (a_p, d_p, g_p) = (a.as_ptr(), d.as_ptr(), grad.as_mut_ptr());
    let mut acc = [[V::zero(); B]; R];
    for t in 0..o.steps {
        let at = a_p.add((t * o.group + s) * o.rows + r0);
        let dt = d_p.add((t * o.group + s) * o.n + j0);
        let mut dv = [V::zero(); B];
        for b in 0..B {
            dv[b] = V::load_ptr(dt.add(b * V::W));
        }
        for i in 0..R {
            let x = V::splat(*at.add(i));
            for b in 0..B {
                acc[i][b] = acc[i][b].mul_then_add(x, dv[b]);
            }
        }
    }
    for i in 0..R {
        for b in 0..B {
            let at = g_p.add((r0 + i) * o.n + j0 + b * V::W);
            V::load_ptr(at).add(acc[i][b]).store_ptr(at);
        }
    }
}

/// One pass of [`outer_tile`] for sample `s` over the lanes `j0..`: blocks of `B * W` lanes,
/// rows in tiles of `R` (the remainder one by one); returns the first lane not covered.
#[inline(always)]
unsafe fn outer_pass<V: Vector, const R: usize, const B: usize>(
    grad: &mut [f32],
    a: &[f32],
    d: &[f32],
    o: &Outer,
    s: usize,
    mut j0: usize,
) -> usize {
    while j0 + B * V::W <= o.n {
        let mut r0 = 0;
        while r0 + R <= o.rows {
            outer_tile::<V, R, B>(grad, a, d, o, s, r0, j0);
            r0 += R;
        }
        // The rows left over as one tile (their sums side by side, each row's order as
        // ever), rather than one tile per row, which would load the gradient rows `d` again
        // for every row.
        match o.rows - r0 {
            0 => {}
            1 => outer_tile::<V, 1, B>(grad, a, d, o, s, r0, j0),
            2 => outer_tile::<V, 2, B>(grad, a, d, o, s, r0, j0),
            3 => outer_tile::<V, 3, B>(grad, a, d, o, s, r0, j0),
            4 => outer_tile::<V, 4, B>(grad, a, d, o, s, r0, j0),
            _ => {
                while r0 < o.rows {
                    outer_tile::<V, 1, B>(grad, a, d, o, s, r0, j0);
                    r0 += 1;
                }
            }
        }
        j0 += B * V::W;
    }
    j0
}

/// The lanes `j0..n` of sample `s` of an `outer_acc`, one scalar at a time (same order).
#[inline(always)]
fn outer_scalar_tail(grad: &mut [f32], a: &[f32], d: &[f32], o: &Outer, s: usize, j0: usize) {
    for r in 0..o.rows {
        for j in j0..o.n {
            let mut acc = 0f32;
            for t in 0..o.steps {
                acc += a[(t * o.group + s) * o.rows + r] * d[(t * o.group + s) * o.n + j];
            }
            grad[r * o.n + j] += acc;
        }
    }
}

/// Checks the sizes of an `outer_acc` call and returns them.
#[inline(always)]
fn outer_check(
    grad: &[f32],
    a: &[f32],
    d: &[f32],
    steps: usize,
    group: usize,
    samples: usize,
) -> Outer {
    let rows = a.len() / (steps * group);
    let n = grad.len() / rows;
    assert!(
        samples <= group
            && a.len() == steps * group * rows
            && d.len() == steps * group * n
            && grad.len() == rows * n,
        "outer_acc: {rows} x {n} gradient, {steps} steps of {samples} of {group} samples"
    );
    Outer {
        steps,
        group,
        rows,
        n,
    }
}

/// The AVX-512 kernels: rows in tiles of 5 samples x 64 lanes (20 accumulators), then 5
/// samples x 16 lanes (the 16-unit hidden gradients: 5 independent chains, so a group of 10
/// samples is two full tiles; tiles of 8 left two samples as single, latency-bound chains, a
/// slower training); outer products in tiles of 5 rows x 64 lanes, then 5 rows x 16 lanes (20
/// accumulators; the rows left over, 4 of the LSTM's 19, as one tile).
pub(crate) struct Avx512;

impl Avx512 {
    /// `rows_acc` (`ZERO` false) or `rows_set` (`ZERO` true).
    #[inline(always)]
    unsafe fn rows<const ZERO: bool>(out: &mut [f32], a: &[f32], m: &[f32], n: usize) {
        rows_check(out, a, m, n);
        let j0 = rows_pass::<__m512, 5, 4, ZERO>(out, a, m, n, 0);
        let j0 = rows_pass::<__m512, 5, 1, ZERO>(out, a, m, n, j0);
        rows_scalar_tail(out, a, m, n, j0, ZERO);
    }
}

impl Mat for Avx512 {
    #[inline(always)]
    unsafe fn rows_acc(out: &mut [f32], a: &[f32], m: &[f32], n: usize) {
        Self::rows::<false>(out, a, m, n)
    }

    #[inline(always)]
    unsafe fn rows_set(out: &mut [f32], a: &[f32], m: &[f32], n: usize) {
        Self::rows::<true>(out, a, m, n)
    }

    #[inline(always)]
    unsafe fn outer_one(
        grad: &mut [f32],
        a: &[f32],
        d: &[f32],
        steps: usize,
        group: usize,
        s: usize,
    ) {
        let o = outer_check(grad, a, d, steps, group, s + 1);
        let j0 = outer_pass::<__m512, 5, 4>(grad, a, d, &o, s, 0);
        let j0 = outer_pass::<__m512, 5, 1>(grad, a, d, &o, s, j0);
        outer_scalar_tail(grad, a, d, &o, s, j0);
    }
}

/// The AVX2 kernels (16 registers): rows in tiles of 2 samples x 32 lanes, then 4 samples x 16
/// lanes, then 8 samples x 8 lanes (8 accumulators each); outer products in tiles of 2 rows x
/// 32 lanes, then 4 rows x 8 lanes.
pub(crate) struct Avx2;

impl Avx2 {
    /// `rows_acc` (`ZERO` false) or `rows_set` (`ZERO` true).
    #[inline(always)]
    unsafe fn rows<const ZERO: bool>(out: &mut [f32], a: &[f32], m: &[f32], n: usize) {
        rows_check(out, a, m, n);
        let j0 = rows_pass::<__m256, 2, 4, ZERO>(out, a, m, n, 0);
        let j0 = rows_pass::<__m256, 4, 2, ZERO>(out, a, m, n, j0);
        let j0 = rows_pass::<__m256, 8, 1, ZERO>(out, a, m, n, j0);
        rows_scalar_tail(out, a, m, n, j0, ZERO);
    }
}

impl Mat for Avx2 {
    #[inline(always)]
    unsafe fn rows_acc(out: &mut [f32], a: &[f32], m: &[f32], n: usize) {
        Self::rows::<false>(out, a, m, n)
    }

    #[inline(always)]
    unsafe fn rows_set(out: &mut [f32], a: &[f32], m: &[f32], n: usize) {
        Self::rows::<true>(out, a, m, n)
    }

    #[inline(always)]
    unsafe fn outer_one(
        grad: &mut [f32],
        a: &[f32],
        d: &[f32],
        steps: usize,
        group: usize,
        s: usize,
    ) {
        let o = outer_check(grad, a, d, steps, group, s + 1);
        let j0 = outer_pass::<__m256, 2, 4>(grad, a, d, &o, s, 0);
        let j0 = outer_pass::<__m256, 4, 1>(grad, a, d, &o, s, j0);
        outer_scalar_tail(grad, a, d, &o, s, j0);
    }
}

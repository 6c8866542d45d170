//! The training kernels: forward pass, backpropagation through time and the gradient of a
//! group of samples, on preallocated `ndarray` buffers.
//!
//! Every sum has a fixed order, written out in the loops below; the loops are vectorised across
//! *independent* output lanes only (the 64 gate pre-activations, the 96 dense outputs, the 16
//! units of a back-propagated hidden gradient), so SIMD never reassociates a sum. There is no
//! fused multiply-add (Rust never contracts `a * b + c`), no BLAS and no ndarray `dot`: the
//! arrays are `ndarray` arrays, but the products run on their contiguous rows (`as_slice`) in
//! the loops written here.
//!
//! Fixed orders, per sample and per lane `j` of the output:
//! - gate pre-activation `z_t[j] = ((0 + x_t[0] W[0][j] + ... + x_t[D-1] W[D-1][j]) + h_{t-1}[0]
//!   U[0][j] + ... + h_{t-1}[H-1] U[H-1][j]) + b[j]`, i.e. one accumulation over the stacked
//!   row vector `[x_t, h_{t-1}, 1]` against the stacked matrix `[kernel; recurrent; bias]`, which
//!   is exactly the flat Keras layout;
//! - dense output `y[j] = (0 + hd[0] V[0][j] + ... + hd[H-1] V[H-1][j]) + c[j]`, the same over
//!   `[hd, 1]` against `[dense kernel; dense bias]`;
//! - back-propagated sums `dh[u] = 0 + U[u][0] dz[0] + ... + U[u][G-1] dz[G-1]` (j ascending);
//! - weight gradients: per sample, `P[r][j] = 0 + a_0[r] d_0[j] + ... + a_{T-1}[r] d_{T-1}[j]`
//!   over time steps t ascending, then `grad[r][j] += P[r][j]` for the samples of the batch in
//!   data order; the SGD step is `w -= grad * lr`, as Keras' SGD.
//!
//! Register blocking: the samples of a group ([`GROUP`]) advance through the time steps in
//! lockstep, stored step-major (`steps x samples x width`), and every matrix product runs in
//! tiles of `S` samples by `L` output lanes: one segment of a weight row is loaded once and
//! multiplied into the accumulators of all `S` samples, which stay in registers for the whole
//! sum. A tile only decides which sums run side by side, never the order of the terms within a
//! sum, so every tile shape gives the same bits (the tests compare every shape with the plain
//! per-sample loops, and whole trainings with a plain per-sample trainer).

// Index loops read several arrays at the same position; iterators would hide that.
#![allow(clippy::needless_range_loop)]

use ndarray::{s, Array1, Array2, Array3, ArrayView2, ArrayView3};

use super::math::{sigmoid_in_place, tanh_in_place};
use super::ModelShape;

/// Samples that advance through the time steps together (the forward and backward passes of a
/// group are interleaved step by step). More samples per group means more independent sums in
/// flight (one sample alone is bound by the latency of its recurrence) and more samples per
/// weight-row load; gradients are still added in sample order, so the bits do not depend on it.
pub(crate) const GROUP: usize = 10;

/// Which samples of a group an outer product covers: the first `n`, added in order, or one.
#[derive(Clone, Copy)]
enum Samples {
    First(usize),
    One(usize),
}

/// The two matrix products of training, as one compiled variant computes them: the portable
/// loops below ([`Tiled`]) or the explicit-SIMD ones of `simd.rs`. Every variant gives the same
/// bits (same terms, same order); they differ in speed only.
pub(crate) trait Mat {
    /// [`rows_acc`]: `out[s][j] += a[s][0] m[0][j] + a[s][1] m[1][j] + ...` (k ascending).
    ///
    /// # Safety
    /// The CPU has the instruction set the variant is compiled for.
    unsafe fn rows_acc(out: &mut [f32], a: &[f32], m: &[f32], n: usize);
    /// [`Mat::rows_acc`] into an `out` that starts at +0, whatever it holds: the bits of
    /// filling it with +0 first (by default exactly that), without reading it.
    ///
    /// # Safety
    /// The CPU has the instruction set the variant is compiled for.
    #[inline(always)]
    unsafe fn rows_set(out: &mut [f32], a: &[f32], m: &[f32], n: usize) {
        out.fill(0.0);
        // SAFETY: the caller's contract is this method's.
        unsafe { Self::rows_acc(out, a, m, n) }
    }
    /// [`outer_one`]: `grad[r][j] += P_s[r][j]` for the one sample `s` of the group.
    ///
    /// # Safety
    /// The CPU has the instruction set the variant is compiled for.
    unsafe fn outer_one(
        grad: &mut [f32],
        a: &[f32],
        d: &[f32],
        steps: usize,
        group: usize,
        s: usize,
    );
    /// [`outer_acc`]: per sample in order, `grad[r][j] += P_s[r][j]`; by default
    /// [`Mat::outer_one`] for each sample in turn (the SIMD variants tile rows, not samples).
    ///
    /// # Safety
    /// The CPU has the instruction set the variant is compiled for.
    #[inline(always)]
    unsafe fn outer_acc(
        grad: &mut [f32],
        a: &[f32],
        d: &[f32],
        steps: usize,
        group: usize,
        samples: usize,
    ) {
        for s in 0..samples {
            // SAFETY: the caller's contract is this method's.
            unsafe { Self::outer_one(grad, a, d, steps, group, s) };
        }
    }
}

/// The portable loops in register tiles of `S` samples by `L` lanes (vectorised by the
/// compiler for whatever the build targets).
pub(crate) struct Tiled<const S: usize, const L: usize>;

impl<const S: usize, const L: usize> Mat for Tiled<S, L> {
    #[inline(always)]
    unsafe fn rows_acc(out: &mut [f32], a: &[f32], m: &[f32], n: usize) {
        rows_acc::<S, L>(out, a, m, n)
    }
    #[inline(always)]
    unsafe fn outer_acc(
        grad: &mut [f32],
        a: &[f32],
        d: &[f32],
        steps: usize,
        group: usize,
        samples: usize,
    ) {
        outer_acc::<S, L>(grad, a, d, steps, group, samples)
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
        outer_one::<L>(grad, a, d, steps, group, s)
    }
}

/// `out[s][j] += a[s][0] m[0][j] + a[s][1] m[1][j] + ...` (k ascending) for every row `s` of
/// `out` (`samples x n`) and `a` (`samples x k`), with `m` row-major `k x n`. Samples run in
/// tiles of `S`, lanes in blocks of `L` (then 16, 8, 1 for the remainders).
#[inline(always)]
pub(crate) fn rows_acc<const S: usize, const L: usize>(
    out: &mut [f32],
    a: &[f32],
    m: &[f32],
    n: usize,
) {
    let samples = out.len() / n;
    let k = m.len() / n;
    assert!(
        out.len() == samples * n && a.len() == samples * k && m.len() == k * n,
        "rows_acc: {samples} x {n} output, {} inputs, {} matrix entries",
        a.len(),
        m.len()
    );
    let mut s0 = 0;
    while s0 + S <= samples {
        rows_lanes::<S, L>(out, a, m, n, k, s0);
        s0 += S;
    }
    while s0 < samples {
        rows_lanes::<1, L>(out, a, m, n, k, s0);
        s0 += 1;
    }
}

#[inline(always)]
fn rows_lanes<const S: usize, const L: usize>(
    out: &mut [f32],
    a: &[f32],
    m: &[f32],
    n: usize,
    k: usize,
    s0: usize,
) {
    let mut j0 = 0;
    while j0 + L <= n {
        rows_tile::<S, L>(out, a, m, n, k, s0, j0);
        j0 += L;
    }
    if L > 16 {
        while j0 + 16 <= n {
            rows_tile::<S, 16>(out, a, m, n, k, s0, j0);
            j0 += 16;
        }
    }
    if L > 8 {
        while j0 + 8 <= n {
            rows_tile::<S, 8>(out, a, m, n, k, s0, j0);
            j0 += 8;
        }
    }
    while j0 < n {
        rows_tile::<S, 1>(out, a, m, n, k, s0, j0);
        j0 += 1;
    }
}

/// One tile: samples `s0..s0 + S`, lanes `j0..j0 + L`, accumulated over all `k` rows.
#[inline(always)]
fn rows_tile<const S: usize, const L: usize>(
    out: &mut [f32],
    a: &[f32],
    m: &[f32],
    n: usize,
    k: usize,
    s0: usize,
    j0: usize,
) {
    let a: &[f32] = &a[s0 * k..(s0 + S) * k];
    let mut acc = [[0f32; L]; S];
    for s in 0..S {
        acc[s].copy_from_slice(&out[(s0 + s) * n + j0..(s0 + s) * n + j0 + L]);
    }
    for (kk, row) in m.chunks_exact(n).enumerate() {
        let row: &[f32; L] = row[j0..j0 + L].try_into().expect("block of L lanes");
        for s in 0..S {
            let ak = a[s * k + kk];
            for l in 0..L {
                acc[s][l] += ak * row[l];
            }
        }
    }
    for s in 0..S {
        out[(s0 + s) * n + j0..(s0 + s) * n + j0 + L].copy_from_slice(&acc[s]);
    }
}

/// For each sample `s < samples` in order: `grad[r][j] += P_s[r][j]` with the partial sum over
/// time steps `P_s[r][j] = 0 + a[0][s][r] d[0][s][j] + ... + a[T-1][s][r] d[T-1][s][j]`.
/// `a` is `steps x group x rows`, `d` is `steps x group x n` (step-major group buffers, of
/// which the first `samples` samples are used), `grad` is `rows x n`.
#[inline(always)]
pub(crate) fn outer_acc<const S: usize, const L: usize>(
    grad: &mut [f32],
    a: &[f32],
    d: &[f32],
    steps: usize,
    group: usize,
    samples: usize,
) {
    outer_range::<S, L>(grad, a, d, steps, group, 0..samples)
}

/// [`outer_acc`] for sample `s` alone: `grad[r][j] += P_s[r][j]`.
#[inline(always)]
pub(crate) fn outer_one<const L: usize>(
    grad: &mut [f32],
    a: &[f32],
    d: &[f32],
    steps: usize,
    group: usize,
    s: usize,
) {
    outer_range::<1, L>(grad, a, d, steps, group, s..s + 1)
}

/// [`outer_acc`] for the samples of `range`, in order.
#[inline(always)]
fn outer_range<const S: usize, const L: usize>(
    grad: &mut [f32],
    a: &[f32],
    d: &[f32],
    steps: usize,
    group: usize,
    range: std::ops::Range<usize>,
) {
    let rows = a.len() / (steps * group);
    let n = grad.len() / rows;
    assert!(
        range.end <= group
            && a.len() == steps * group * rows
            && d.len() == steps * group * n
            && grad.len() == rows * n,
        "outer_acc: {rows} x {n} gradient, {steps} steps, samples {range:?} of {group}"
    );
    let dims = OuterDims {
        steps,
        group,
        rows,
        n,
    };
    for r in 0..rows {
        let g = &mut grad[r * n..(r + 1) * n];
        let mut s0 = range.start;
        while s0 + S <= range.end {
            outer_lanes::<S, L>(g, a, d, &dims, r, s0);
            s0 += S;
        }
        while s0 < range.end {
            outer_lanes::<1, L>(g, a, d, &dims, r, s0);
            s0 += 1;
        }
    }
}

/// Sizes of an [`outer_acc`].
struct OuterDims {
    steps: usize,
    group: usize,
    rows: usize,
    n: usize,
}

#[inline(always)]
fn outer_lanes<const S: usize, const L: usize>(
    g: &mut [f32],
    a: &[f32],
    d: &[f32],
    dims: &OuterDims,
    r: usize,
    s0: usize,
) {
    let n = dims.n;
    let mut j0 = 0;
    while j0 + L <= n {
        outer_tile::<S, L>(g, a, d, dims, r, s0, j0);
        j0 += L;
    }
    if L > 16 {
        while j0 + 16 <= n {
            outer_tile::<S, 16>(g, a, d, dims, r, s0, j0);
            j0 += 16;
        }
    }
    if L > 8 {
        while j0 + 8 <= n {
            outer_tile::<S, 8>(g, a, d, dims, r, s0, j0);
            j0 += 8;
        }
    }
    while j0 < n {
        outer_tile::<S, 1>(g, a, d, dims, r, s0, j0);
        j0 += 1;
    }
}

/// One tile: row `r`, samples `s0..s0 + S`, lanes `j0..j0 + L`; the samples' partial sums
/// are added to `g` in sample order.
#[inline(always)]
fn outer_tile<const S: usize, const L: usize>(
    g: &mut [f32],
    a: &[f32],
    d: &[f32],
    dims: &OuterDims,
    r: usize,
    s0: usize,
    j0: usize,
) {
    let (group, rows, n) = (dims.group, dims.rows, dims.n);
    let mut acc = [[0f32; L]; S];
    for t in 0..dims.steps {
        let a_t = &a[t * group * rows..(t + 1) * group * rows];
        let d_t = &d[t * group * n..(t + 1) * group * n];
        for s in 0..S {
            let x = a_t[(s0 + s) * rows + r];
            let row: &[f32; L] = d_t[(s0 + s) * n + j0..(s0 + s) * n + j0 + L]
                .try_into()
                .expect("block of L lanes");
            for l in 0..L {
                acc[s][l] += x * row[l];
            }
        }
    }
    let target: &mut [f32; L] = (&mut g[j0..j0 + L]).try_into().expect("block of L lanes");
    for s in 0..S {
        for l in 0..L {
            target[l] += acc[s][l];
        }
    }
}

/// The first `n` samples of step `t` of a step-major buffer, row-major. (Plain index
/// arithmetic on the array's contiguous data: `ArrayBase::slice` costs a call per step here.)
#[inline(always)]
fn step(a: &Array3<f32>, t: usize, n: usize) -> &[f32] {
    let (_, group, width) = a.dim();
    let at = t * group * width;
    &a.as_slice()
        .expect("workspace arrays have the standard layout")[at..at + n * width]
}

/// [`step`], mutable.
#[inline(always)]
fn step_mut(a: &mut Array3<f32>, t: usize, n: usize) -> &mut [f32] {
    let (_, group, width) = a.dim();
    let at = t * group * width;
    &mut a
        .as_slice_mut()
        .expect("workspace arrays have the standard layout")[at..at + n * width]
}

/// Steps `t` and `t + 1` of a step-major buffer (first `n` samples of each), the second mutable.
#[inline(always)]
fn step_pair_mut(a: &mut Array3<f32>, t: usize, n: usize) -> (&[f32], &mut [f32]) {
    let (_, group, width) = a.dim();
    let at = t * group * width;
    let all = a
        .as_slice_mut()
        .expect("workspace arrays have the standard layout");
    let (this, next) = all[at..].split_at_mut(group * width);
    (&this[..n * width], &mut next[..n * width])
}

/// The first `n` rows of a matrix, row-major.
#[inline(always)]
fn head(a: &Array2<f32>, n: usize) -> &[f32] {
    let width = a.ncols();
    &a.as_slice()
        .expect("workspace arrays have the standard layout")[..n * width]
}

/// [`head`], mutable.
#[inline(always)]
fn head_mut(a: &mut Array2<f32>, n: usize) -> &mut [f32] {
    let width = a.ncols();
    &mut a
        .as_slice_mut()
        .expect("workspace arrays have the standard layout")[..n * width]
}

/// The contiguous data of a standard-layout view.
#[inline(always)]
fn flat<'a>(a: ArrayView2<'a, f32>) -> &'a [f32] {
    a.to_slice().expect("weights are row-major views")
}

/// The two layers of a flat weight (or gradient) vector as matrices, without copies: the
/// stacked LSTM matrix `[kernel; recurrent; bias]` (`rows_lstm x gates`) and the stacked dense
/// matrix `[kernel; bias]` (`(units + 1) x outputs`).
pub(crate) struct Layers<'a> {
    pub(crate) lstm: ArrayView2<'a, f32>,
    pub(crate) dense: ArrayView2<'a, f32>,
}

impl<'a> Layers<'a> {
    pub(crate) fn new(shape: &ModelShape, flat: &'a [f32]) -> Layers<'a> {
        let (lstm, dense) = flat.split_at(shape.dense_offset());
        Layers {
            lstm: ArrayView2::from_shape((shape.rows_lstm(), shape.gates()), lstm)
                .expect("flat weights have the model's length"),
            dense: ArrayView2::from_shape((shape.units() + 1, shape.outputs()), dense)
                .expect("flat weights have the model's length"),
        }
    }
}

/// Every buffer one training needs, allocated once. Per-sample buffers hold [`GROUP`] samples;
/// those read per time step are step-major (`steps x GROUP x width`), so that a step of the
/// whole group is one contiguous row-major matrix.
pub(crate) struct Workspace {
    pub(crate) shape: ModelShape,
    /// Per step t, per sample: the stacked row `[x_t, h_{t-1}, 1]` (`steps x GROUP x rows_lstm`).
    xh: Array3<f32>,
    /// Per step, per sample: activated gates i, f, g, o (`steps x GROUP x gates`).
    gates: Array3<f32>,
    /// Cell states c_0 = 0, c_1, ..., c_T (`(steps + 1) x GROUP x units`).
    cs: Array3<f32>,
    /// tanh(c_t) for t = 1..T (`steps x GROUP x units`).
    tanh_c: Array3<f32>,
    /// Gate pre-activation gradients (`steps x GROUP x gates`).
    dz: Array3<f32>,
    /// Per sample: `[h_T * mask, 1]` (`GROUP x (units + 1)`).
    hd1: Array2<f32>,
    /// Per sample: the dense output (`GROUP x outputs`).
    y: Array2<f32>,
    /// Per sample: gradient of the loss with respect to the dense output.
    dy: Array2<f32>,
    /// Per sample: gradient with respect to the hidden state of the current step.
    dh: Array2<f32>,
    /// Per sample: gradient with respect to the cell state of the current step.
    dc: Array2<f32>,
    /// Per sample: dropout mask (0 or 1 / (1 - p)) (`GROUP x units`).
    pub(crate) mask: Array2<f32>,
    /// Recurrent kernel transposed (`gates x units`).
    rec_t: Array2<f32>,
    /// Dense kernel transposed (`outputs x units`).
    dense_t: Array2<f32>,
    /// Gradient of the batch, flat layout (see [`Layers`] for its matrices).
    pub(crate) grad: Array1<f32>,
}

impl Workspace {
    pub(crate) fn new(shape: &ModelShape) -> Workspace {
        assert!(
            shape.units >= 1 && shape.input_steps >= 1 && shape.output_steps >= 1,
            "model sizes must be positive (Config::validate checks them): {shape:?}"
        );
        let (t, h, g, r1, o) = (
            shape.steps_in(),
            shape.units(),
            shape.gates(),
            shape.rows_lstm(),
            shape.outputs(),
        );
        Workspace {
            shape: shape.clone(),
            xh: Array3::zeros((t, GROUP, r1)),
            gates: Array3::zeros((t, GROUP, g)),
            cs: Array3::zeros((t + 1, GROUP, h)),
            tanh_c: Array3::zeros((t, GROUP, h)),
            dz: Array3::zeros((t, GROUP, g)),
            hd1: Array2::zeros((GROUP, h + 1)),
            y: Array2::zeros((GROUP, o)),
            dy: Array2::zeros((GROUP, o)),
            dh: Array2::zeros((GROUP, h)),
            dc: Array2::zeros((GROUP, h)),
            mask: Array2::ones((GROUP, h)),
            rec_t: Array2::zeros((g, h)),
            dense_t: Array2::zeros((o, h)),
            grad: Array1::zeros(shape.weights()),
        }
    }

    /// Refreshes the transposed copies of the weights (once per batch: weights are constant
    /// within a batch).
    pub(crate) fn transpose_weights(&mut self, w: &[f32]) {
        let layers = Layers::new(&self.shape, w);
        let (d, h) = (self.shape.input_dims(), self.shape.units());
        self.rec_t.assign(&layers.lstm.slice(s![d..d + h, ..]).t());
        self.dense_t.assign(&layers.dense.slice(s![..h, ..]).t());
    }

    /// Forward pass of up to [`GROUP`] samples (`inputs`: samples x steps x 2), each with its
    /// dropout mask, with the matrix products of `M`; leaves the outputs in `y` and every
    /// intermediate for the backward pass.
    ///
    /// # Safety
    /// The CPU has the instruction set `M` is compiled for.
    #[inline(always)]
    pub(crate) unsafe fn forward<M: Mat>(&mut self, w: &[f32], inputs: ArrayView3<f32>) {
        let n = inputs.len_of(ndarray::Axis(0));
        assert!((1..=GROUP).contains(&n));
        let sh = &self.shape;
        let (t_n, d, h, g, r1, o) = (
            sh.steps_in(),
            sh.input_dims(),
            sh.units(),
            sh.gates(),
            sh.rows_lstm(),
            sh.outputs(),
        );
        assert_eq!(inputs.dim(), (n, t_n, d), "inputs of another model shape");
        let layers = Layers::new(sh, w);
        let (lstm, dense) = (flat(layers.lstm), flat(layers.dense));
        // The stacked rows' constant parts: x_t for every step, h_{-1} = 0, the bias input 1.
        let x = inputs.to_slice().expect("a range of samples is contiguous");
        for t in 0..t_n {
            let xh = step_mut(&mut self.xh, t, n);
            for i in 0..n {
                let row = &mut xh[i * r1..(i + 1) * r1];
                row[..d].copy_from_slice(&x[(i * t_n + t) * d..(i * t_n + t + 1) * d]);
                if t == 0 {
                    row[d..d + h].fill(0.0);
                }
                row[d + h] = 1.0;
            }
        }
        step_mut(&mut self.cs, 0, n).fill(0.0);
        for t in 0..t_n {
            let z = step_mut(&mut self.gates, t, n);
            // SAFETY: the caller guarantees the CPU runs `M`.
            unsafe { M::rows_set(z, step(&self.xh, t, n), lstm, g) };
            for zi in z.chunks_exact_mut(g) {
                sigmoid_in_place(&mut zi[..2 * h]);
                tanh_in_place(&mut zi[2 * h..3 * h]);
                sigmoid_in_place(&mut zi[3 * h..]);
            }
            let z = step(&self.gates, t, n);
            let (c_prev, c_next) = step_pair_mut(&mut self.cs, t, n);
            for i in 0..n {
                let (zi, cp, cn) = (
                    &z[i * g..(i + 1) * g],
                    &c_prev[i * h..(i + 1) * h],
                    &mut c_next[i * h..(i + 1) * h],
                );
                for u in 0..h {
                    cn[u] = zi[h + u] * cp[u] + zi[u] * zi[2 * h + u];
                }
            }
            let tc = step_mut(&mut self.tanh_c, t, n);
            tc.copy_from_slice(c_next);
            tanh_in_place(tc);
            let tc = step(&self.tanh_c, t, n);
            // h_t = o * tanh(c_t) goes into the next step's stacked row, or after the last step
            // into the dense layer's input.
            let (h_out, stride, at) = if t + 1 < t_n {
                (step_mut(&mut self.xh, t + 1, n), r1, d)
            } else {
                (head_mut(&mut self.hd1, n), h + 1, 0)
            };
            for i in 0..n {
                let (zi, tci) = (&z[i * g..(i + 1) * g], &tc[i * h..(i + 1) * h]);
                let hi = &mut h_out[i * stride + at..i * stride + at + h];
                for u in 0..h {
                    hi[u] = zi[3 * h + u] * tci[u];
                }
            }
        }
        let mask = head(&self.mask, n);
        let hd1 = head_mut(&mut self.hd1, n);
        for i in 0..n {
            let row = &mut hd1[i * (h + 1)..(i + 1) * (h + 1)];
            for u in 0..h {
                row[u] *= mask[i * h + u];
            }
            row[h] = 1.0;
        }
        let y = head_mut(&mut self.y, n);
        // SAFETY: as above.
        unsafe { M::rows_set(y, head(&self.hd1, n), dense, o) };
    }

    /// The output of sample `s` of the last [`Workspace::forward`].
    pub(crate) fn output(&self, s: usize) -> &[f32] {
        self.y
            .row(s)
            .to_slice()
            .expect("workspace arrays have the standard layout")
    }

    /// Squared error of sample `s` of the last forward pass against `target`, summed in f64
    /// over the outputs in order; also stores `dy = (y - target) * grad_scale`.
    #[inline(always)]
    pub(crate) fn error(&mut self, s: usize, target: &[f32], grad_scale: f32) -> f64 {
        let o = self.shape.outputs();
        let y = &self.y.as_slice().expect("standard layout")[s * o..(s + 1) * o];
        let dy = &mut self.dy.as_slice_mut().expect("standard layout")[s * o..(s + 1) * o];
        let mut sse = 0.0f64;
        for j in 0..o {
            let e = y[j] - target[j];
            sse += f64::from(e) * f64::from(e);
            dy[j] = e * grad_scale;
        }
        sse
    }

    /// Backward pass of the first `n` samples of the last forward pass, with output gradients
    /// `dy`, with the matrix products of `M`; adds their gradients into `grad`, sample after
    /// sample: [`Workspace::backward_dz`], then [`Workspace::accumulate`].
    ///
    /// # Safety
    /// The CPU has the instruction set `M` is compiled for.
    #[inline(always)]
    pub(crate) unsafe fn backward<M: Mat>(&mut self, n: usize) {
        // SAFETY: the caller guarantees the CPU runs `M`.
        unsafe { self.backward_dz::<M>(n) };
        let mut grad = std::mem::replace(&mut self.grad, Array1::zeros(0));
        // SAFETY: as above.
        unsafe { self.accumulate::<M>(grad.as_slice_mut().expect("standard layout"), n) };
        self.grad = grad;
    }

    /// Adds the gradients of the first `n` samples of the last [`Workspace::backward_dz`] into
    /// `grad` (flat layout), sample after sample: the dense layer's, then the LSTM's. The two
    /// are disjoint parts of `grad`, so their order does not matter; within each, samples are
    /// added in order.
    ///
    /// # Safety
    /// The CPU has the instruction set `M` is compiled for.
    #[inline(always)]
    pub(crate) unsafe fn accumulate<M: Mat>(&self, grad: &mut [f32], n: usize) {
        assert!((1..=GROUP).contains(&n));
        // SAFETY: the caller guarantees the CPU runs `M`.
        unsafe { self.outer_into::<M>(grad, Samples::First(n)) };
    }

    /// The gradient of each of the first `n` samples of the last [`Workspace::backward_dz`]
    /// alone, into row `s` of `partials` (flat layout, one row per sample): the terms
    /// [`Workspace::accumulate`] adds for that sample, summed in the same order. Adding the rows
    /// into a gradient in sample order ([`add_partials`]) then gives the bits `accumulate` gives:
    /// each row starts from -0, which `x + -0 = x` leaves exact for every `x`.
    ///
    /// # Safety
    /// The CPU has the instruction set `M` is compiled for.
    #[inline(always)]
    pub(crate) unsafe fn partials<M: Mat>(&self, partials: &mut Array2<f32>, n: usize) {
        assert!((1..=GROUP).contains(&n));
        assert_eq!(
            partials.ncols(),
            self.shape.weights(),
            "partials of another model shape"
        );
        for s in 0..n {
            let mut row = partials.row_mut(s);
            let p = row
                .as_slice_mut()
                .expect("workspace arrays have the standard layout");
            p.fill(-0.0);
            // SAFETY: the caller guarantees the CPU runs `M`.
            unsafe { self.outer_into::<M>(p, Samples::One(s)) };
        }
    }

    /// The weight gradient's two outer products added into `grad` (flat layout): the dense
    /// layer's (`[h_T * mask, 1]` by the output gradients, one step), then the LSTM's (the
    /// stacked rows `[x_t, h_{t-1}, 1]` by the gate gradients, every step), for the samples
    /// `samples` names. The two are disjoint parts of `grad`, so their order does not matter.
    ///
    /// # Safety
    /// The CPU has the instruction set `M` is compiled for.
    #[inline(always)]
    unsafe fn outer_into<M: Mat>(&self, grad: &mut [f32], samples: Samples) {
        let sh = &self.shape;
        let (grad_lstm, grad_dense) = grad.split_at_mut(sh.dense_offset());
        let layout = "workspace arrays have the standard layout";
        let parts = [
            (
                grad_dense,
                self.hd1.as_slice().expect(layout),
                self.dy.as_slice().expect(layout),
                1,
            ),
            (
                grad_lstm,
                self.xh.as_slice().expect(layout),
                self.dz.as_slice().expect(layout),
                sh.steps_in(),
            ),
        ];
        for (g, a, d, steps) in parts {
            // SAFETY: the caller guarantees the CPU runs `M`.
            unsafe {
                match samples {
                    Samples::First(n) => M::outer_acc(g, a, d, steps, GROUP, n),
                    Samples::One(s) => M::outer_one(g, a, d, steps, GROUP, s),
                }
            }
        }
    }

    /// Backpropagation through time of the first `n` samples of the last forward pass, with
    /// output gradients `dy`: leaves the gate pre-activation gradients in `dz` (what
    /// [`Workspace::accumulate`] multiplies into the weight gradients) and writes no gradient.
    ///
    /// # Safety
    /// The CPU has the instruction set `M` is compiled for.
    #[inline(always)]
    pub(crate) unsafe fn backward_dz<M: Mat>(&mut self, n: usize) {
        assert!((1..=GROUP).contains(&n));
        let sh = &self.shape;
        let (t_n, h, g) = (sh.steps_in(), sh.units(), sh.gates());
        let dh = head_mut(&mut self.dh, n);
        // SAFETY: the caller guarantees the CPU runs `M`.
        unsafe {
            M::rows_set(
                dh,
                head(&self.dy, n),
                self.dense_t.as_slice().expect("standard layout"),
                h,
            )
        };
        for (dh, m) in dh.iter_mut().zip(head(&self.mask, n)) {
            *dh *= *m;
        }
        head_mut(&mut self.dc, n).fill(0.0);
        let rec_t = self.rec_t.as_slice().expect("standard layout");
        for t in (0..t_n).rev() {
            let z = step(&self.gates, t, n);
            let c_prev = step(&self.cs, t, n);
            let tc = step(&self.tanh_c, t, n);
            let dz = step_mut(&mut self.dz, t, n);
            let dh = head(&self.dh, n);
            let dc = head_mut(&mut self.dc, n);
            for i in 0..n {
                let zi = &z[i * g..(i + 1) * g];
                let (cp, tci) = (&c_prev[i * h..(i + 1) * h], &tc[i * h..(i + 1) * h]);
                let dzi = &mut dz[i * g..(i + 1) * g];
                let (dhi, dci) = (&dh[i * h..(i + 1) * h], &mut dc[i * h..(i + 1) * h]);
                for u in 0..h {
                    let (ig, fg, gg, og) = (zi[u], zi[h + u], zi[2 * h + u], zi[3 * h + u]);
                    let dhu = dhi[u];
                    let d_o = dhu * tci[u];
                    let dcu = dci[u] + dhu * og * (1.0 - tci[u] * tci[u]);
                    dzi[u] = dcu * gg * (ig * (1.0 - ig));
                    dzi[h + u] = dcu * cp[u] * (fg * (1.0 - fg));
                    dzi[2 * h + u] = dcu * ig * (1.0 - gg * gg);
                    dzi[3 * h + u] = d_o * (og * (1.0 - og));
                    dci[u] = dcu * fg;
                }
            }
            if t > 0 {
                let dh = head_mut(&mut self.dh, n);
                // SAFETY: as above.
                unsafe { M::rows_set(dh, step(&self.dz, t, n), rec_t, h) };
            }
        }
    }
}

/// `grad += partials[s]` for the first `n` rows of `partials` in order: the second half of
/// [`Workspace::accumulate`] after [`Workspace::partials`] (same bits).
#[inline(always)]
pub(crate) fn add_partials(grad: &mut [f32], partials: &Array2<f32>, n: usize) {
    for s in 0..n {
        let row = partials.row(s);
        let p = row
            .as_slice()
            .expect("workspace arrays have the standard layout");
        assert_eq!(p.len(), grad.len(), "partials of another model shape");
        for (g, v) in grad.iter_mut().zip(p) {
            *g += *v;
        }
    }
}

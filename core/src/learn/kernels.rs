//! The training kernels: forward pass, backpropagation through time and the SGD step of one
//! mini-batch, on preallocated buffers.
//!
//! Every sum has a fixed order, written out in the loops below; the loops are vectorised across
//! *independent* output lanes only (the 64 gate pre-activations, the 96 dense outputs, the 16
//! units of a back-propagated hidden gradient), so SIMD never reassociates a sum. There is no
//! fused multiply-add (Rust never contracts `a * b + c`), no BLAS and no ndarray `dot`.
//!
//! Fixed orders, per lane `j` of the output:
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

// Index loops read several arrays at the same position; iterators would hide that.
#![allow(clippy::needless_range_loop)]

use super::math::{sigmoid_in_place, tanh_in_place};
use super::ModelShape;

/// `out[j] += a[0] m[0][j] + a[1] m[1][j] + ...` (k ascending) for a row-major `m` of
/// `a.len()` rows and `out.len()` columns.
#[inline(always)]
pub(crate) fn rows_acc(out: &mut [f32], a: &[f32], m: &[f32]) {
    let n = out.len();
    debug_assert_eq!(m.len(), a.len() * n);
    let mut j0 = 0;
    while j0 + 32 <= n {
        rows_acc_block::<32>(out, a, m, n, j0);
        j0 += 32;
    }
    if j0 + 16 <= n {
        rows_acc_block::<16>(out, a, m, n, j0);
        j0 += 16;
    }
    while j0 + 8 <= n {
        rows_acc_block::<8>(out, a, m, n, j0);
        j0 += 8;
    }
    while j0 < n {
        rows_acc_block::<1>(out, a, m, n, j0);
        j0 += 1;
    }
}

#[inline(always)]
fn rows_acc_block<const L: usize>(out: &mut [f32], a: &[f32], m: &[f32], n: usize, j0: usize) {
    let target: &mut [f32; L] = (&mut out[j0..j0 + L]).try_into().expect("block of L lanes");
    let mut acc = *target;
    for (k, &ak) in a.iter().enumerate() {
        let row: &[f32; L] = m[k * n + j0..k * n + j0 + L]
            .try_into()
            .expect("block of L lanes");
        for l in 0..L {
            acc[l] += ak * row[l];
        }
    }
    *target = acc;
}

/// `grad[r][j] += sum over t ascending of a[t][r] d[t][j]`, the partial sum over t starting
/// from 0 and added to `grad` once. `a` is `steps x rows`, `d` is `steps x n`, `grad` is
/// `rows x n`, all row-major.
#[inline(always)]
pub(crate) fn outer_acc(grad: &mut [f32], a: &[f32], d: &[f32], steps: usize, rows: usize) {
    let n = d.len() / steps;
    debug_assert_eq!(a.len(), steps * rows);
    debug_assert_eq!(grad.len(), rows * n);
    for r in 0..rows {
        let g = &mut grad[r * n..(r + 1) * n];
        let mut j0 = 0;
        while j0 + 32 <= n {
            outer_block::<32>(g, a, d, steps, rows, r, n, j0);
            j0 += 32;
        }
        if j0 + 16 <= n {
            outer_block::<16>(g, a, d, steps, rows, r, n, j0);
            j0 += 16;
        }
        while j0 + 8 <= n {
            outer_block::<8>(g, a, d, steps, rows, r, n, j0);
            j0 += 8;
        }
        while j0 < n {
            outer_block::<1>(g, a, d, steps, rows, r, n, j0);
            j0 += 1;
        }
    }
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn outer_block<const L: usize>(
    g: &mut [f32],
    a: &[f32],
    d: &[f32],
    steps: usize,
    rows: usize,
    r: usize,
    n: usize,
    j0: usize,
) {
    let mut acc = [0f32; L];
    for t in 0..steps {
        let s = a[t * rows + r];
        let row: &[f32; L] = d[t * n + j0..t * n + j0 + L]
            .try_into()
            .expect("block of L lanes");
        for l in 0..L {
            acc[l] += s * row[l];
        }
    }
    let target: &mut [f32; L] = (&mut g[j0..j0 + L]).try_into().expect("block of L lanes");
    for l in 0..L {
        target[l] += acc[l];
    }
}

/// Samples processed together: their forward and backward passes are interleaved step by step,
/// so that the CPU overlaps their independent dependency chains (one sample alone is bound by
/// the latency of its recurrence). Each sample's arithmetic is unchanged by the grouping, and
/// gradients are still added in sample order: the bits do not depend on the group size.
pub(crate) const GROUP: usize = 4;

/// Every buffer one training needs, allocated once; per-sample buffers exist [`GROUP`] times.
pub(crate) struct Workspace {
    pub(crate) shape: ModelShape,
    /// Per sample, per step t: the stacked row `[x_t, h_{t-1}, 1]` (`steps x rows_lstm`).
    xh: Vec<f32>,
    /// Per sample, per step: activated gates i, f, g, o (`steps x gates`).
    gates: Vec<f32>,
    /// Per sample: cell states c_0 = 0, c_1, ..., c_T (`(steps + 1) x units`).
    cs: Vec<f32>,
    /// Per sample: tanh(c_t) for t = 1..T (`steps x units`).
    tanh_c: Vec<f32>,
    /// Per sample: gate pre-activation gradients per step (`steps x gates`).
    dz: Vec<f32>,
    /// Per sample: `[h_T * mask, 1]`.
    hd1: Vec<f32>,
    /// Per sample: the dense output.
    y: Vec<f32>,
    /// Per sample: gradient of the loss with respect to the dense output.
    dy: Vec<f32>,
    dh: Vec<f32>,
    dc: Vec<f32>,
    /// Per sample: dropout mask (0 or 1 / (1 - p)).
    pub(crate) mask: Vec<f32>,
    /// Recurrent kernel transposed (`gates x units`).
    rec_t: Vec<f32>,
    /// Dense kernel transposed (`outputs x units`).
    dense_t: Vec<f32>,
    /// Gradient of the batch, flat layout.
    pub(crate) grad: Vec<f32>,
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
            xh: vec![0.0; GROUP * t * r1],
            gates: vec![0.0; GROUP * t * g],
            cs: vec![0.0; GROUP * (t + 1) * h],
            tanh_c: vec![0.0; GROUP * t * h],
            dz: vec![0.0; GROUP * t * g],
            hd1: vec![0.0; GROUP * (h + 1)],
            y: vec![0.0; GROUP * o],
            dy: vec![0.0; GROUP * o],
            dh: vec![0.0; GROUP * h],
            dc: vec![0.0; GROUP * h],
            mask: vec![1.0; GROUP * h],
            rec_t: vec![0.0; g * h],
            dense_t: vec![0.0; o * h],
            grad: vec![0.0; shape.weights()],
        }
    }

    /// Refreshes the transposed copies of the weights (once per batch: weights are constant
    /// within a batch).
    #[inline(always)]
    pub(crate) fn transpose_weights(&mut self, w: &[f32]) {
        let s = &self.shape;
        let (d, h, g, o) = (s.input_dims(), s.units(), s.gates(), s.outputs());
        for u in 0..h {
            for j in 0..g {
                self.rec_t[j * h + u] = w[(d + u) * g + j];
            }
        }
        let dense = &w[s.dense_offset()..];
        for k in 0..h {
            for j in 0..o {
                self.dense_t[j * h + k] = dense[k * o + j];
            }
        }
    }

    /// The dropout mask of sample `s` of the group.
    pub(crate) fn mask_mut(&mut self, s: usize) -> &mut [f32] {
        let h = self.shape.units();
        &mut self.mask[s * h..(s + 1) * h]
    }

    /// Forward pass of up to [`GROUP`] samples (`inputs[s]`: steps x 2 values), each with its
    /// dropout mask; leaves the outputs in `y` and every intermediate for the backward pass.
    #[inline(always)]
    pub(crate) fn forward(&mut self, w: &[f32], inputs: &[&[f32]]) {
        let n = inputs.len();
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
        let lstm = &w[..r1 * g];
        let (xh_n, g_n, c_n, tc_n) = (t_n * r1, t_n * g, (t_n + 1) * h, t_n * h);
        for s in 0..n {
            self.cs[s * c_n..s * c_n + h].fill(0.0);
        }
        for t in 0..t_n {
            for (s, x) in inputs.iter().enumerate() {
                let xh = &mut self.xh[s * xh_n + t * r1..s * xh_n + (t + 1) * r1];
                xh[..d].copy_from_slice(&x[t * d..(t + 1) * d]);
                if t == 0 {
                    xh[d..d + h].fill(0.0);
                }
                xh[d + h] = 1.0;
                let z = &mut self.gates[s * g_n + t * g..s * g_n + (t + 1) * g];
                z.fill(0.0);
                rows_acc(z, xh, lstm);
            }
            for s in 0..n {
                let z = &mut self.gates[s * g_n + t * g..s * g_n + (t + 1) * g];
                sigmoid_in_place(&mut z[..2 * h]);
                tanh_in_place(&mut z[2 * h..3 * h]);
                sigmoid_in_place(&mut z[3 * h..]);
            }
            for s in 0..n {
                let z = &self.gates[s * g_n + t * g..s * g_n + (t + 1) * g];
                let cs = &mut self.cs[s * c_n + t * h..s * c_n + (t + 2) * h];
                let (c_prev, c_next) = cs.split_at_mut(h);
                let tc = &mut self.tanh_c[s * tc_n + t * h..s * tc_n + (t + 1) * h];
                for u in 0..h {
                    c_next[u] = z[h + u] * c_prev[u] + z[u] * z[2 * h + u];
                    tc[u] = c_next[u];
                }
                tanh_in_place(tc);
            }
            for s in 0..n {
                let z = &self.gates[s * g_n + t * g..s * g_n + (t + 1) * g];
                let tc = &self.tanh_c[s * tc_n + t * h..s * tc_n + (t + 1) * h];
                let h_out: &mut [f32] = if t + 1 < t_n {
                    let at = s * xh_n + (t + 1) * r1 + d;
                    &mut self.xh[at..at + h]
                } else {
                    &mut self.hd1[s * (h + 1)..s * (h + 1) + h]
                };
                for u in 0..h {
                    h_out[u] = z[3 * h + u] * tc[u];
                }
            }
        }
        let dense = &w[r1 * g..r1 * g + (h + 1) * o];
        for s in 0..n {
            let hd1 = &mut self.hd1[s * (h + 1)..(s + 1) * (h + 1)];
            for u in 0..h {
                hd1[u] *= self.mask[s * h + u];
            }
            hd1[h] = 1.0;
            let y = &mut self.y[s * o..(s + 1) * o];
            y.fill(0.0);
            rows_acc(y, hd1, dense);
        }
    }

    /// The output of sample `s` of the last [`Workspace::forward`].
    pub(crate) fn output(&self, s: usize) -> &[f32] {
        let o = self.shape.outputs();
        &self.y[s * o..(s + 1) * o]
    }

    /// Squared error of sample `s` of the last forward pass against `target`, summed in f64
    /// over the outputs in order; also stores `dy = (y - target) * grad_scale`.
    #[inline(always)]
    pub(crate) fn error(&mut self, s: usize, target: &[f32], grad_scale: f32) -> f64 {
        let o = self.shape.outputs();
        let y = &self.y[s * o..(s + 1) * o];
        let dy = &mut self.dy[s * o..(s + 1) * o];
        let mut sse = 0.0f64;
        for j in 0..o {
            let e = y[j] - target[j];
            sse += f64::from(e) * f64::from(e);
            dy[j] = e * grad_scale;
        }
        sse
    }

    /// Backward pass of the first `n` samples of the last forward pass, with output gradients
    /// `dy`; adds their gradients into `grad`, sample after sample.
    #[inline(always)]
    pub(crate) fn backward(&mut self, n: usize) {
        assert!((1..=GROUP).contains(&n));
        let sh = &self.shape;
        let (t_n, h, g, r1, o) = (
            sh.steps_in(),
            sh.units(),
            sh.gates(),
            sh.rows_lstm(),
            sh.outputs(),
        );
        let dense_off = sh.dense_offset();
        let (xh_n, g_n, c_n, tc_n) = (t_n * r1, t_n * g, (t_n + 1) * h, t_n * h);
        // Dense layer: gradient of [kernel; bias] and of the (masked) last hidden state.
        for s in 0..n {
            outer_acc(
                &mut self.grad[dense_off..],
                &self.hd1[s * (h + 1)..(s + 1) * (h + 1)],
                &self.dy[s * o..(s + 1) * o],
                1,
                h + 1,
            );
        }
        for s in 0..n {
            let dh = &mut self.dh[s * h..(s + 1) * h];
            dh.fill(0.0);
            rows_acc(dh, &self.dy[s * o..(s + 1) * o], &self.dense_t);
            for u in 0..h {
                dh[u] *= self.mask[s * h + u];
            }
        }
        self.dc[..n * h].fill(0.0);
        for t in (0..t_n).rev() {
            for s in 0..n {
                let z = &self.gates[s * g_n + t * g..s * g_n + (t + 1) * g];
                let c_prev = &self.cs[s * c_n + t * h..s * c_n + (t + 1) * h];
                let tc = &self.tanh_c[s * tc_n + t * h..s * tc_n + (t + 1) * h];
                let dz = &mut self.dz[s * g_n + t * g..s * g_n + (t + 1) * g];
                let dh_s = &self.dh[s * h..(s + 1) * h];
                let dc_s = &mut self.dc[s * h..(s + 1) * h];
                for u in 0..h {
                    let (i, f, gg, oo) = (z[u], z[h + u], z[2 * h + u], z[3 * h + u]);
                    let dh = dh_s[u];
                    let d_o = dh * tc[u];
                    let dc = dc_s[u] + dh * oo * (1.0 - tc[u] * tc[u]);
                    dz[u] = dc * gg * (i * (1.0 - i));
                    dz[h + u] = dc * c_prev[u] * (f * (1.0 - f));
                    dz[2 * h + u] = dc * i * (1.0 - gg * gg);
                    dz[3 * h + u] = d_o * (oo * (1.0 - oo));
                    dc_s[u] = dc * f;
                }
            }
            if t > 0 {
                for s in 0..n {
                    let dh = &mut self.dh[s * h..(s + 1) * h];
                    dh.fill(0.0);
                    rows_acc(
                        dh,
                        &self.dz[s * g_n + t * g..s * g_n + (t + 1) * g],
                        &self.rec_t,
                    );
                }
            }
        }
        for s in 0..n {
            outer_acc(
                &mut self.grad[..r1 * g],
                &self.xh[s * xh_n..(s + 1) * xh_n],
                &self.dz[s * g_n..(s + 1) * g_n],
                t_n,
                r1,
            );
        }
    }
}

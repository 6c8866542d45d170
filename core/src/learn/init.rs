//! Keras-default initialisation of the model, drawn from a seeded stream.
//!
//! Keras initialises, in this order: the LSTM kernel (glorot-uniform), the recurrent kernel
//! (orthogonal), the LSTM bias (zeros, forget gate ones: `unit_forget_bias`), the Dense kernel
//! (glorot-uniform) and the Dense bias (zeros). We draw in the same order from one [`Rng`]
//! (the genesis stream, `Purpose::ModelInit`).

use super::ModelShape;
use crate::rng::Rng;

/// Fresh weights in the flat Keras layout (see the module documentation of `learn`).
pub fn init_weights(shape: &ModelShape, rng: &mut Rng) -> Vec<f32> {
    let (d, h, g, o) = (
        shape.input_dims(),
        shape.units(),
        shape.gates(),
        shape.outputs(),
    );
    let mut w = Vec::with_capacity(shape.weights());
    w.extend(glorot_uniform(d, g, rng));
    w.extend(orthogonal(h, g, rng));
    w.extend((0..g).map(|j| if (h..2 * h).contains(&j) { 1.0 } else { 0.0 }));
    w.extend(glorot_uniform(h, o, rng));
    w.extend(std::iter::repeat_n(0.0, o));
    assert_eq!(w.len(), shape.weights());
    w
}

/// Uniform in [-l, l) with l = sqrt(6 / (fan_in + fan_out)), row-major `fan_in x fan_out`.
fn glorot_uniform(fan_in: usize, fan_out: usize, rng: &mut Rng) -> Vec<f32> {
    let limit = libm::sqrt(6.0 / (fan_in + fan_out) as f64);
    (0..fan_in * fan_out)
        .map(|_| (limit * (2.0 * rng.uniform() - 1.0)) as f32)
        .collect()
}

/// Keras' `Orthogonal(gain=1)` for a `rows x cols` kernel: a Gaussian matrix of shape
/// `max x min` (drawn row-major), its QR decomposition with the signs of R's diagonal folded
/// into Q (so that the decomposition is unique), transposed if `rows < cols`. We compute the
/// unique QR with positive diagonal directly by modified Gram-Schmidt, re-orthogonalised once,
/// in f64: the same Q as Householder QR plus Keras' sign correction.
fn orthogonal(rows: usize, cols: usize, rng: &mut Rng) -> Vec<f32> {
    let (tall, narrow) = (rows.max(cols), rows.min(cols));
    // a[i][j], i < tall, j < narrow; columns are orthonormalised.
    let mut a: Vec<f64> = (0..tall * narrow).map(|_| rng.normal()).collect();
    for j in 0..narrow {
        for _pass in 0..2 {
            for p in 0..j {
                let dot: f64 = (0..tall)
                    .map(|i| a[i * narrow + p] * a[i * narrow + j])
                    .sum();
                for i in 0..tall {
                    a[i * narrow + j] -= dot * a[i * narrow + p];
                }
            }
        }
        let norm = libm::sqrt(
            (0..tall)
                .map(|i| a[i * narrow + j] * a[i * narrow + j])
                .sum(),
        );
        for i in 0..tall {
            a[i * narrow + j] /= norm;
        }
    }
    let mut out = vec![0f32; rows * cols];
    for r in 0..rows {
        for c in 0..cols {
            // Q is tall x narrow; the kernel is Q itself (rows >= cols) or its transpose.
            let q = if rows >= cols {
                a[r * narrow + c]
            } else {
                a[c * narrow + r]
            };
            out[r * cols + c] = q as f32;
        }
    }
    out
}

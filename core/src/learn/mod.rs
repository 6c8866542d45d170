//! The model and its deterministic local training (docs/SPEC.md section 2).
//!
//! The model is the paper's: LSTM(`units`) over `input_waypoints` steps of (x, y), dropout,
//! Dense(2 * `target_waypoints`), read as (`target_waypoints`, 2). Its weights are one flat
//! `Vec<f32>` in the Keras layout (LSTM kernel `2 x 4H`, recurrent kernel `H x 4H`, bias `4H`,
//! Dense kernel `H x O`, Dense bias `O`; gate order i, f, c, o; row-major): 2848 values for the
//! paper's sizes. Training holds them, their gradient, the data and every activation in
//! `ndarray` arrays (the layers are `Array2` views of the flat vector; the data and the
//! per-step activations `Array3`), and runs its products on their contiguous rows.
//!
//! Training is a pure function of (shape, config, start weights, data, dropout stream): plain
//! SGD on the mean squared error with full backpropagation through time, in `f32` as
//! TensorFlow, with every sum in a fixed order (`kernels.rs`) and activations built from IEEE basic
//! operations in a fixed order ([`math`]: within 1 ulp, checked on all 2^32 inputs). The result is the same bits on any number of threads, in debug
//! or release, and on any x86-64 build; AVX-512 or AVX2 code is selected at run time where the CPU has
//! it and is tested to give the same bits as the baseline code.
//!
//! Submodules: [`init`] (Keras-default initialisation), [`math`] (lane-wise exp, sigmoid, tanh),
//! `kernels.rs` (forward, backward, SGD), [`fixed`] (on-chain fixed point).

mod background;
pub mod fixed;
pub mod init;
pub(crate) mod kernels;
pub mod math;
mod pair;

pub use pair::set_allowed as allow_two_thread_training;
#[cfg(target_arch = "x86_64")]
mod simd;
mod subnormals;
#[cfg(test)]
mod tests;

use ndarray::{s, Array1, Array2, Array3, ArrayView3, Axis};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::config::{Config, Frame, LearnConfig};
use crate::data::Sample;
use crate::rng::Rng;

pub use background::Spawned;
pub use fixed::{from_fixed, to_fixed, FixedPointError};
pub use init::init_weights;
use kernels::{Mat, Tiled, Workspace, GROUP};

/// Coordinates per waypoint (x, y).
const POINT_DIMS: usize = 2;

/// The sizes of the model; everything else (offsets, weight count) derives from them. All three
/// are at least 1 (as `Config::validate` ensures); training asserts it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModelShape {
    /// LSTM units H.
    pub units: u32,
    /// Input time steps (waypoints fed to the LSTM).
    pub input_steps: u32,
    /// Predicted waypoints (the Dense layer has 2x this many outputs).
    pub output_steps: u32,
    /// The coordinates samples are given in (`learn.frame`).
    pub frame: Frame,
}

impl ModelShape {
    /// The shape configured in `learn.lstm_units`, `data.input_waypoints` and
    /// `data.target_waypoints`.
    pub fn from_config(config: &Config) -> ModelShape {
        ModelShape {
            units: config.learn.lstm_units,
            input_steps: config.data.input_waypoints,
            output_steps: config.data.target_waypoints,
            frame: config.learn.frame,
        }
    }

    /// Number of trainable weights: `4H (2 + H + 1) + O (H + 1)`; 2848 for the paper's model.
    pub fn weights(&self) -> usize {
        self.rows_lstm() * self.gates() + (self.units() + 1) * self.outputs()
    }

    /// Floating-point operations of one training sample pass (forward and backward, without
    /// the SGD step), counting each add and multiply as one and each sigmoid/tanh as one.
    pub fn flops_per_train_sample(&self) -> u64 {
        let (t, h, g, r1, o) = (
            self.steps_in() as u64,
            self.units() as u64,
            self.gates() as u64,
            self.rows_lstm() as u64,
            self.outputs() as u64,
        );
        let forward = self.flops_per_eval_sample();
        // Error and its gradient (subtract, square, accumulate, scale).
        let loss = 4 * o;
        // Dense: kernel/bias gradient (multiply, add, add into grad), hidden gradient, mask.
        let dense_back = 3 * (h + 1) * o + 2 * o * h + h;
        // Per step: 22 elementwise operations per unit (gate derivatives), the hidden gradient
        // (all steps but the first), the kernel gradient partials; then adding them once.
        let lstm_back = t * 22 * h + (t - 1) * 2 * g * h + t * 2 * r1 * g + r1 * g;
        forward + loss + dense_back + lstm_back
    }

    /// Floating-point operations of one evaluation (forward-only) sample pass.
    pub fn flops_per_eval_sample(&self) -> u64 {
        let (t, h, g, r1, o) = (
            self.steps_in() as u64,
            self.units() as u64,
            self.gates() as u64,
            self.rows_lstm() as u64,
            self.outputs() as u64,
        );
        // Gates (multiply-add over the stacked row), 4H activations, cell update (3 per
        // unit), tanh(c), h = o * tanh(c); then mask and the dense layer.
        t * (2 * r1 * g + g + 3 * h + h + h) + h + 2 * (h + 1) * o
    }

    pub(crate) fn units(&self) -> usize {
        self.units as usize
    }
    pub(crate) fn steps_in(&self) -> usize {
        self.input_steps as usize
    }
    pub(crate) fn input_dims(&self) -> usize {
        POINT_DIMS
    }
    pub(crate) fn gates(&self) -> usize {
        4 * self.units()
    }
    /// Rows of the stacked LSTM matrix `[kernel; recurrent; bias]`.
    pub(crate) fn rows_lstm(&self) -> usize {
        POINT_DIMS + self.units() + 1
    }
    pub(crate) fn outputs(&self) -> usize {
        POINT_DIMS * self.output_steps as usize
    }
    /// Offset of the Dense kernel in the flat layout.
    pub(crate) fn dense_offset(&self) -> usize {
        self.rows_lstm() * self.gates()
    }
    fn input_len(&self) -> usize {
        POINT_DIMS * self.steps_in()
    }
}

/// Errors building a training set.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LearnError {
    /// A sample has fewer waypoints than the model reads.
    #[error(
        "sample {index} has {points} waypoints but the model needs {needed} \
         (data.input_waypoints + data.target_waypoints); record full trajectories"
    )]
    SampleTooShort {
        /// Index of the sample in the slice given.
        index: usize,
        /// Waypoints it has.
        points: usize,
        /// Waypoints needed.
        needed: usize,
    },
}

/// A data set in the model's layout, oldest sample first: the inputs as a `samples x
/// input_steps x 2` array of (x, y), the targets as `samples x 2 * output_steps`. A batch is a
/// view of a range of samples.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainData {
    shape: ModelShape,
    inputs: Array3<f32>,
    targets: Array2<f32>,
}

impl TrainData {
    /// Builds the data set from samples (oldest first), in the shape's frame: world metres, or
    /// each sample's waypoints minus its last input waypoint (`learn.frame = "relative"`; an
    /// exact f32 subtraction, the same on every machine). Waypoints beyond input + target are
    /// ignored (docs/SPEC.md: waypoints 80..100 are unused); a shorter sample is an error.
    pub fn new(shape: &ModelShape, samples: &[Sample]) -> Result<TrainData, LearnError> {
        let (n_in, n_out) = (shape.steps_in(), shape.output_steps as usize);
        let mut inputs = Vec::with_capacity(samples.len() * shape.input_len());
        let mut targets = Vec::with_capacity(samples.len() * shape.outputs());
        for (index, sample) in samples.iter().enumerate() {
            if sample.points.len() < n_in + n_out {
                return Err(LearnError::SampleTooShort {
                    index,
                    points: sample.points.len(),
                    needed: n_in + n_out,
                });
            }
            let (past, future) = (&sample.points[..n_in], &sample.points[n_in..n_in + n_out]);
            match shape.frame {
                Frame::World => {
                    inputs.extend(past.iter().flatten());
                    targets.extend(future.iter().flatten());
                }
                Frame::Relative => {
                    let o = past[n_in - 1];
                    let moved = |p: &[f32; 2]| [p[0] - o[0], p[1] - o[1]];
                    inputs.extend(past.iter().flat_map(moved));
                    targets.extend(future.iter().flat_map(moved));
                }
            }
        }
        let inputs = Array3::from_shape_vec((samples.len(), n_in, POINT_DIMS), inputs);
        let targets = Array2::from_shape_vec((samples.len(), shape.outputs()), targets);
        Ok(TrainData {
            shape: shape.clone(),
            inputs: inputs.expect("input_steps points per sample"),
            targets: targets.expect("target_waypoints points per sample"),
        })
    }

    /// Builds the data set from flat arrays: `inputs` is `samples x input_steps x 2`, `targets`
    /// is `samples x output_steps x 2`, both row-major. Returns `None` if the lengths do not fit.
    pub fn from_flat(shape: &ModelShape, inputs: Vec<f32>, targets: Vec<f32>) -> Option<TrainData> {
        let n_in = shape.input_len();
        let n_out = shape.outputs();
        if n_in == 0 || n_out == 0 || !inputs.len().is_multiple_of(n_in) {
            return None;
        }
        let len = inputs.len() / n_in;
        if targets.len() != len * n_out {
            return None;
        }
        Some(TrainData {
            shape: shape.clone(),
            inputs: Array3::from_shape_vec((len, shape.steps_in(), POINT_DIMS), inputs).ok()?,
            targets: Array2::from_shape_vec((len, n_out), targets).ok()?,
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.inputs.len_of(Axis(0))
    }

    /// True if there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The first `n` samples (all of them if there are fewer).
    pub fn head(&self, n: usize) -> TrainData {
        let n = n.min(self.len());
        TrainData {
            shape: self.shape.clone(),
            inputs: self.inputs.slice(s![..n, .., ..]).to_owned(),
            targets: self.targets.slice(s![..n, ..]).to_owned(),
        }
    }

    /// The inputs of samples `from..to` (`samples x input_steps x 2`).
    fn inputs(&self, from: usize, to: usize) -> ArrayView3<'_, f32> {
        self.inputs.slice(s![from..to, .., ..])
    }

    fn target(&self, i: usize) -> &[f32] {
        self.targets
            .row(i)
            .to_slice()
            .expect("owned arrays have the standard layout")
    }
}

/// The result of one local training.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainOutcome {
    /// The trained weights (the start weights unchanged if there was nothing to train on).
    pub weights: Vec<f32>,
    /// Samples in the training split (the n_k the robot reports).
    pub train_samples: u32,
    /// Samples in the validation split.
    pub val_samples: u32,
    /// Mean squared error of the trained model on the validation split, dropout off; NaN if
    /// the validation split is empty.
    pub val_loss: f64,
    /// Mean squared error over the training samples of the last epoch, each measured in its
    /// batch's forward pass (dropout on, before that batch's update), as Keras reports `loss`;
    /// NaN if no training step ran.
    pub final_train_loss: f64,
}

/// Which compiled variant of the kernels runs. They give identical bits; the choice is speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// The best the CPU supports (AVX2 if detected at run time, else baseline).
    Auto,
    /// Baseline x86-64 (SSE2) or the target's default code.
    Baseline,
    /// AVX2 code (x86-64 only; falls back to baseline if the CPU lacks AVX2).
    Avx2,
    /// AVX-512 code (x86-64 only; falls back to AVX2, then baseline, if the CPU lacks it).
    Avx512,
}

/// The compiled code a [`Kernel`] resolves to on this CPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Resolved {
    Baseline,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Kernel {
    fn resolve(self) -> Resolved {
        #[cfg(target_arch = "x86_64")]
        {
            let avx512 = std::arch::is_x86_feature_detected!("avx512f");
            let avx2 = std::arch::is_x86_feature_detected!("avx2");
            match self {
                Kernel::Baseline => Resolved::Baseline,
                Kernel::Auto | Kernel::Avx512 if avx512 => Resolved::Avx512,
                _ if avx2 => Resolved::Avx2,
                _ => Resolved::Baseline,
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = self;
            Resolved::Baseline
        }
    }

    /// The code this variant runs on this CPU: "avx512", "avx2" or "baseline".
    pub fn describe(self) -> &'static str {
        match self.resolve() {
            Resolved::Baseline => "baseline",
            #[cfg(target_arch = "x86_64")]
            Resolved::Avx2 => "avx2",
            #[cfg(target_arch = "x86_64")]
            Resolved::Avx512 => "avx512",
        }
    }
}

/// The chronological split: the first `floor(n * train_fraction)` samples train, the rest
/// validate (Keras' `validation_split` rule).
pub fn split_point(samples: usize, train_fraction: f64) -> usize {
    let at = (samples as f64 * train_fraction).floor();
    if at.is_nan() || at <= 0.0 {
        0
    } else {
        (at as usize).min(samples)
    }
}

/// One local training: SGD on the MSE from `start`, `cfg.epochs` passes over the first
/// `floor(n * cfg.train_fraction)` samples in order (no shuffling) in batches of
/// `cfg.batch_size` (the last batch may be smaller, as Keras), dropout after the LSTM with
/// masks from `dropout`; then the validation loss of the trained model on the remaining
/// samples. With no training samples (or 0 epochs) the weights come back unchanged. NaN in the
/// data propagates into the weights and losses; it never panics.
///
/// Dropout draws `units` values `u = dropout.uniform_f32()` per training sample pass (samples
/// in order), keeping a unit iff `u >= p` and scaling kept units by `1 / (1 - p)` (f32).
///
/// The epochs run with subnormal numbers flushed to zero (x86-64's FTZ and DAZ, as TensorFlow
/// on a CPU; `subnormals.rs` says why and what it changes); the validation loss does not.
///
/// Panics if `start.len() != shape.weights()` or `data` was built for another shape (internal
/// invariants: the contract only stores models of the right length).
pub fn train(
    shape: &ModelShape,
    cfg: &LearnConfig,
    start: &[f32],
    data: &TrainData,
    dropout: Rng,
) -> TrainOutcome {
    train_with(Kernel::Auto, shape, cfg, start, data, dropout)
}

/// How many threads one training uses. Every choice gives the same bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Threads {
    /// Two when it helps: helpers are allowed ([`allow_two_thread_training`]), rayon's pool
    /// has at least two threads, the batch has at least two groups of samples and no other
    /// training is in progress in this process (see `pair.rs`); else one.
    Auto,
    /// This thread only.
    One,
    /// Two, even while other trainings run (for the bit-identity tests and benchmarks).
    Two,
}

/// [`train`] with an explicit kernel variant (for benchmarks and the bit-identity tests).
pub fn train_with(
    kernel: Kernel,
    shape: &ModelShape,
    cfg: &LearnConfig,
    start: &[f32],
    data: &TrainData,
    dropout: Rng,
) -> TrainOutcome {
    train_threads(kernel, Threads::Auto, shape, cfg, start, data, dropout)
}

/// [`train_with`] with an explicit thread choice.
pub fn train_threads(
    kernel: Kernel,
    threads: Threads,
    shape: &ModelShape,
    cfg: &LearnConfig,
    start: &[f32],
    data: &TrainData,
    mut dropout: Rng,
) -> TrainOutcome {
    assert_eq!(
        start.len(),
        shape.weights(),
        "start weights do not fit the model shape"
    );
    assert_eq!(
        &data.shape, shape,
        "training data built for another model shape"
    );
    let n_train = split_point(data.len(), cfg.train_fraction);
    let n_val = data.len() - n_train;
    let mut weights = Array1::from(start.to_vec());
    let mut final_train_loss = f64::NAN;
    if n_train > 0 && cfg.epochs > 0 && cfg.batch_size > 0 {
        let sgd = Sgd {
            epochs: cfg.epochs,
            batch: cfg.batch_size as usize,
            lr: cfg.learning_rate as f32,
            dropout: cfg.dropout as f32,
            samples: n_train,
        };
        let flush = subnormals::FlushSubnormals::enter();
        final_train_loss = epochs(
            kernel,
            threads,
            shape,
            &sgd,
            &mut weights,
            data,
            &mut dropout,
        );
        drop(flush);
    }
    let weights = weights.to_vec();
    let val_loss = if n_val > 0 {
        loss_range_with(kernel, shape, &weights, data, n_train, data.len())
    } else {
        f64::NAN
    };
    TrainOutcome {
        weights,
        train_samples: n_train as u32,
        val_samples: n_val as u32,
        val_loss,
        final_train_loss,
    }
}

/// [`train_threads`]'s SGD epochs, on this thread or two; the last epoch's training loss. Its
/// caller holds a [`subnormals::FlushSubnormals`] around the call, and the pair's helper
/// thread its own: not inlined, so no arithmetic of it moves out of that mode.
#[inline(never)]
fn epochs(
    kernel: Kernel,
    threads: Threads,
    shape: &ModelShape,
    sgd: &Sgd,
    weights: &mut Array1<f32>,
    data: &TrainData,
    dropout: &mut Rng,
) -> f64 {
    let single = |weights: &mut Array1<f32>, dropout: &mut Rng| {
        let mut ws = Workspace::new(shape);
        dispatch_train(kernel, &mut ws, weights, data, sgd, dropout)
    };
    let two = match threads {
        Threads::One => false,
        Threads::Two => true,
        Threads::Auto => pair::worth_it(sgd.samples, sgd.batch),
    };
    if two {
        let force = threads == Threads::Two;
        pair::train(kernel.resolve(), force, weights, data, sgd, dropout, single)
    } else {
        single(weights, dropout)
    }
}

/// Mean squared error of `weights` over every sample of `data` (dropout off), NaN for an empty
/// set. Squared errors are summed in f64: samples in order, the outputs of each in order.
pub fn loss(shape: &ModelShape, weights: &[f32], data: &TrainData) -> f64 {
    assert_eq!(
        weights.len(),
        shape.weights(),
        "weights do not fit the model shape"
    );
    assert_eq!(&data.shape, shape, "data built for another model shape");
    loss_range_with(Kernel::Auto, shape, weights, data, 0, data.len())
}

/// The model's output for every sample of `data` (dropout off), `samples x 2 * output_steps`.
pub fn predict(shape: &ModelShape, weights: &[f32], data: &TrainData) -> Vec<f32> {
    assert_eq!(
        weights.len(),
        shape.weights(),
        "weights do not fit the model shape"
    );
    assert_eq!(&data.shape, shape, "data built for another model shape");
    let mut ws = Workspace::new(shape);
    let mut out = Vec::with_capacity(data.len() * shape.outputs());
    for (first, last) in groups(0, data.len()) {
        // SAFETY: the portable kernels run on any CPU.
        unsafe { ws.forward::<Portable>(weights, data.inputs(first, last)) };
        for s in 0..last - first {
            out.extend_from_slice(ws.output(s));
        }
    }
    out
}

/// The gradient of the mean squared error over all samples of `data` (one batch, dropout
/// off) and that loss (f64 sum as in [`loss`]).
pub fn gradient(shape: &ModelShape, weights: &[f32], data: &TrainData) -> (Vec<f32>, f64) {
    assert_eq!(
        weights.len(),
        shape.weights(),
        "weights do not fit the model shape"
    );
    assert_eq!(&data.shape, shape, "data built for another model shape");
    let mut ws = Workspace::new(shape);
    ws.transpose_weights(weights);
    let scale = grad_scale(data.len(), shape.outputs());
    let mut sse = 0.0;
    for (first, last) in groups(0, data.len()) {
        // SAFETY: the portable kernels run on any CPU.
        unsafe { ws.forward::<Portable>(weights, data.inputs(first, last)) };
        for (s, i) in (first..last).enumerate() {
            sse += ws.error(s, data.target(i), scale);
        }
        // SAFETY: as above.
        unsafe { ws.backward::<Portable>(last - first) };
    }
    (
        ws.grad.to_vec(),
        sse / (data.len() * shape.outputs()) as f64,
    )
}

/// The groups of at most [`GROUP`] consecutive samples that cover `from..to`, in order.
fn groups(from: usize, to: usize) -> impl Iterator<Item = (usize, usize)> {
    (from..to)
        .step_by(GROUP)
        .map(move |first| (first, (first + GROUP).min(to)))
}

/// One robot's training, for [`train_many`] or [`Spawned::start`].
#[derive(Clone, Debug)]
pub struct TrainJob {
    /// Model sizes.
    pub shape: ModelShape,
    /// Training hyper-parameters.
    pub cfg: LearnConfig,
    /// Start weights (the shared model in the robot's view of the chain).
    pub start: Vec<f32>,
    /// The robot's data set, oldest first.
    pub data: TrainData,
    /// The robot's dropout stream.
    pub dropout: Rng,
}

impl TrainJob {
    /// Trains: [`train_threads`] with the fastest kernel, two threads if no other training
    /// runs ([`Threads::Auto`]).
    pub fn run(self) -> TrainOutcome {
        self.run_with(Threads::Auto)
    }

    fn run_with(self, threads: Threads) -> TrainOutcome {
        train_threads(
            Kernel::Auto,
            threads,
            &self.shape,
            &self.cfg,
            &self.start,
            &self.data,
            self.dropout,
        )
    }
}

/// Runs the jobs in parallel (rayon) and returns their outcomes in job order. Every job is
/// independent, so the bits do not depend on the number of threads.
pub fn train_many(jobs: Vec<TrainJob>) -> Vec<TrainOutcome> {
    // Several trainings fill the cores by themselves; one alone may use two threads.
    let threads = if jobs.len() > 1 {
        Threads::One
    } else {
        Threads::Auto
    };
    jobs.into_par_iter()
        .map(|job| job.run_with(threads))
        .collect()
}

/// The portable matrix kernels (baseline x86-64 and other targets): tiles of 4 samples x 8
/// lanes, 8 of the 16 SSE registers. AVX2 and AVX-512 use the explicit-SIMD kernels of `simd`.
type Portable = Tiled<4, 8>;

/// SGD settings of one training.
struct Sgd {
    epochs: u32,
    batch: usize,
    lr: f32,
    dropout: f32,
    samples: usize,
}

impl Sgd {
    /// The mini-batches of one epoch, in order: `(first, end)` sample ranges (the last may be
    /// shorter, as Keras).
    fn batches(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.samples)
            .step_by(self.batch)
            .map(|first| (first, (first + self.batch).min(self.samples)))
    }

    /// Draws the dropout masks of the first `n` samples of a group into the first `n` rows of
    /// `mask` (`GROUP x units`), samples in order: `units` draws each, a unit kept iff
    /// `u >= p` and scaled by `1 / (1 - p)`.
    fn draw_masks(&self, mask: &mut Array2<f32>, n: usize, dropout: &mut Rng) {
        let keep_scale = 1.0f32 / (1.0f32 - self.dropout);
        for s in 0..n {
            let mut row = mask.row_mut(s);
            for m in row
                .as_slice_mut()
                .expect("workspace arrays have the standard layout")
            {
                let keep = dropout.uniform_f32() >= self.dropout;
                *m = if keep { keep_scale } else { 0.0 };
            }
        }
    }
}

/// d(mean of squares)/dy = 2 e / (batch * outputs), in f32.
fn grad_scale(batch: usize, outputs: usize) -> f32 {
    2.0f32 / (batch * outputs) as f32
}

fn dispatch_train(
    kernel: Kernel,
    ws: &mut Workspace,
    weights: &mut Array1<f32>,
    data: &TrainData,
    sgd: &Sgd,
    dropout: &mut Rng,
) -> f64 {
    match kernel.resolve() {
        Resolved::Baseline => {
            // SAFETY: the portable kernels run on any CPU.
            unsafe { train_loop::<Portable>(ws, weights, data, sgd, dropout) }
        }
        // SAFETY: `resolve` checked at run time that the CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Resolved::Avx2 => unsafe { train_avx2(ws, weights, data, sgd, dropout) },
        // SAFETY: `resolve` checked at run time that the CPU has AVX-512F.
        #[cfg(target_arch = "x86_64")]
        Resolved::Avx512 => unsafe { train_avx512(ws, weights, data, sgd, dropout) },
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn train_avx512(
    ws: &mut Workspace,
    weights: &mut Array1<f32>,
    data: &TrainData,
    sgd: &Sgd,
    dropout: &mut Rng,
) -> f64 {
    // SAFETY: this function's caller checked the CPU.
    unsafe { train_loop::<simd::Avx512>(ws, weights, data, sgd, dropout) }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn train_avx2(
    ws: &mut Workspace,
    weights: &mut Array1<f32>,
    data: &TrainData,
    sgd: &Sgd,
    dropout: &mut Rng,
) -> f64 {
    // SAFETY: this function's caller checked the CPU.
    unsafe { train_loop::<simd::Avx2>(ws, weights, data, sgd, dropout) }
}

/// The epochs of SGD; returns the last epoch's training loss.
///
/// # Safety
/// The CPU has the instruction set `M` is compiled for.
#[inline(always)]
unsafe fn train_loop<M: Mat>(
    ws: &mut Workspace,
    weights: &mut Array1<f32>,
    data: &TrainData,
    sgd: &Sgd,
    dropout: &mut Rng,
) -> f64 {
    let outputs = ws.shape.outputs();
    let mut epoch_sse = 0.0f64;
    for _ in 0..sgd.epochs {
        epoch_sse = 0.0;
        for (start, end) in sgd.batches() {
            let scale = grad_scale(end - start, outputs);
            let w = weights
                .as_slice()
                .expect("owned arrays have the standard layout");
            ws.transpose_weights(w);
            ws.grad.fill(0.0);
            for (first, last) in groups(start, end) {
                sgd.draw_masks(&mut ws.mask, last - first, dropout);
                // SAFETY: this function's caller guarantees the CPU runs `M`.
                unsafe { ws.forward::<M>(w, data.inputs(first, last)) };
                for (s, i) in (first..last).enumerate() {
                    epoch_sse += ws.error(s, data.target(i), scale);
                }
                // SAFETY: as above.
                unsafe { ws.backward::<M>(last - first) };
            }
            weights.zip_mut_with(&ws.grad, |w, g| *w -= *g * sgd.lr);
        }
    }
    ws.mask.fill(1.0);
    epoch_sse / (sgd.samples * outputs) as f64
}

fn loss_range_with(
    kernel: Kernel,
    shape: &ModelShape,
    weights: &[f32],
    data: &TrainData,
    from: usize,
    to: usize,
) -> f64 {
    if from >= to {
        return f64::NAN;
    }
    let mut ws = Workspace::new(shape);
    match kernel.resolve() {
        Resolved::Baseline => {
            // SAFETY: the portable kernels run on any CPU.
            unsafe { loss_loop::<Portable>(&mut ws, weights, data, from, to) }
        }
        // SAFETY: `resolve` checked at run time that the CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Resolved::Avx2 => unsafe { loss_avx2(&mut ws, weights, data, from, to) },
        // SAFETY: `resolve` checked at run time that the CPU has AVX-512F.
        #[cfg(target_arch = "x86_64")]
        Resolved::Avx512 => unsafe { loss_avx512(&mut ws, weights, data, from, to) },
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn loss_avx512(
    ws: &mut Workspace,
    weights: &[f32],
    data: &TrainData,
    from: usize,
    to: usize,
) -> f64 {
    // SAFETY: this function's caller checked the CPU.
    unsafe { loss_loop::<simd::Avx512>(ws, weights, data, from, to) }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn loss_avx2(
    ws: &mut Workspace,
    weights: &[f32],
    data: &TrainData,
    from: usize,
    to: usize,
) -> f64 {
    // SAFETY: this function's caller checked the CPU.
    unsafe { loss_loop::<simd::Avx2>(ws, weights, data, from, to) }
}

/// Mean squared error over the samples `from..to` (dropout off).
///
/// # Safety
/// The CPU has the instruction set `M` is compiled for.
#[inline(always)]
unsafe fn loss_loop<M: Mat>(
    ws: &mut Workspace,
    weights: &[f32],
    data: &TrainData,
    from: usize,
    to: usize,
) -> f64 {
    ws.mask.fill(1.0);
    let mut sse = 0.0f64;
    for (first, last) in groups(from, to) {
        // SAFETY: this function's caller guarantees the CPU runs `M`.
        unsafe { ws.forward::<M>(weights, data.inputs(first, last)) };
        for (s, i) in (first..last).enumerate() {
            sse += ws.error(s, data.target(i), 0.0);
        }
    }
    sse / ((to - from) * ws.shape.outputs()) as f64
}

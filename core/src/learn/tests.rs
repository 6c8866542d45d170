//! Tests of the learning module against TensorFlow/Keras, finite differences, and itself.

use super::*;
use crate::rng::{stream, Purpose};

fn paper_shape() -> ModelShape {
    ModelShape {
        units: 16,
        input_steps: 32,
        output_steps: 48,
    }
}

fn learn_cfg(epochs: u32, lr: f64, dropout: f64, train_fraction: f64) -> LearnConfig {
    let mut cfg = Config::default().learn;
    cfg.epochs = epochs;
    cfg.learning_rate = lr;
    cfg.dropout = dropout;
    cfg.train_fraction = train_fraction;
    cfg.batch_size = 20;
    cfg
}

/// The Keras fixture (fixtures/keras/lstm_fixture.json, made by make_fixture.py).
struct Fixture {
    init: Vec<f32>,
    data: TrainData,
    outputs: Vec<f32>,
    loss: f64,
    grads: Vec<f32>,
    after_epoch: Vec<f32>,
    learning_rate: f64,
}

fn fixture() -> Fixture {
    let text = include_str!("../../../fixtures/keras/lstm_fixture.json");
    let v: serde_json::Value = serde_json::from_str(text).expect("fixture is JSON");
    let floats = |key: &str| -> Vec<f32> {
        v[key]
            .as_array()
            .expect(key)
            .iter()
            .map(|x| x.as_f64().expect(key) as f32)
            .collect()
    };
    let shape = paper_shape();
    assert_eq!(v["units"], 16);
    let data = TrainData::from_flat(&shape, floats("x"), floats("y")).expect("fixture sizes");
    Fixture {
        init: floats("init"),
        data,
        outputs: floats("outputs"),
        loss: v["loss"].as_f64().expect("loss"),
        grads: floats("grads"),
        after_epoch: floats("after_epoch"),
        learning_rate: v["learning_rate"].as_f64().expect("learning_rate"),
    }
}

/// Largest relative deviation of `ours` from `keras`, with relative meaning
/// |a - b| / max(|b|, floor) and floor = `floor_frac` * RMS(b) over the array: an entry far
/// smaller than the array's typical magnitude is the sum of terms of that typical magnitude,
/// so its f32 rounding error scales with the RMS, not with the entry itself. Entries at least
/// as large as the floor are compared purely relatively. Returns (deviation, index).
fn max_rel_dev(ours: &[f32], keras: &[f32], floor_frac: f64) -> (f64, usize) {
    assert_eq!(ours.len(), keras.len());
    let rms =
        (keras.iter().map(|b| f64::from(*b).powi(2)).sum::<f64>() / keras.len() as f64).sqrt();
    let floor = (floor_frac * rms).max(f64::MIN_POSITIVE);
    let mut worst = (0.0, 0);
    for (i, (a, b)) in ours.iter().zip(keras).enumerate() {
        let dev = (f64::from(*a) - f64::from(*b)).abs() / f64::from(b.abs()).max(floor);
        if dev > worst.0 || dev.is_nan() {
            worst = (dev, i);
        }
    }
    worst
}

const REL_TOL: f64 = 1e-5;
/// Entries smaller than the array's RMS are compared against the RMS.
const FLOOR_FRAC: f64 = 1.0;

#[test]
fn matches_keras_forward_loss_gradients_and_one_epoch() {
    let fx = fixture();
    let shape = paper_shape();
    assert_eq!(fx.init.len(), shape.weights());

    let out = predict(&shape, &fx.init, &fx.data);
    let (dev_out, i_out) = max_rel_dev(&out, &fx.outputs, FLOOR_FRAC);

    let (grads, loss) = gradient(&shape, &fx.init, &fx.data);
    let dev_loss = (loss - fx.loss).abs() / fx.loss.abs();
    let (dev_grad, i_grad) = max_rel_dev(&grads, &fx.grads, FLOOR_FRAC);
    let loss_again = super::loss(&shape, &fx.init, &fx.data);
    assert_eq!(
        loss.to_bits(),
        loss_again.to_bits(),
        "gradient() and loss() sum the same way"
    );

    let cfg = learn_cfg(1, fx.learning_rate, 0.0, 1.0);
    let trained = train(
        &shape,
        &cfg,
        &fx.init,
        &fx.data,
        stream(0, Purpose::Dropout, 0),
    );
    assert_eq!(trained.train_samples, 50);
    let (dev_after, i_after) = max_rel_dev(&trained.weights, &fx.after_epoch, FLOOR_FRAC);
    // The update itself (after - init) is ~1e-4 of the weights; compare it separately, against
    // the typical update (f32 rounding of w - lr g alone is ~1e-3 of an update).
    let delta = |w: &[f32]| -> Vec<f32> { w.iter().zip(&fx.init).map(|(a, b)| a - b).collect() };
    let (dev_delta, i_delta) = max_rel_dev(&delta(&trained.weights), &delta(&fx.after_epoch), 1.0);

    eprintln!(
        "keras fixture, largest relative deviations: outputs {dev_out:.3e} (#{i_out}), \
         loss {dev_loss:.3e}, gradients {dev_grad:.3e} (#{i_grad}), weights after one epoch \
         {dev_after:.3e} (#{i_after}), update vs largest update {dev_delta:.3e} (#{i_delta})"
    );
    assert!(
        dev_out <= REL_TOL,
        "outputs deviate by {dev_out:e} at {i_out}"
    );
    assert!(dev_loss <= REL_TOL, "loss {loss} vs keras {}", fx.loss);
    assert!(
        dev_grad <= REL_TOL,
        "gradients deviate by {dev_grad:e} at {i_grad}"
    );
    assert!(
        dev_after <= REL_TOL,
        "weights after one epoch deviate by {dev_after:e} at {i_after}"
    );
    assert!(
        dev_delta <= 1e-2,
        "updates deviate by {dev_delta:e} at {i_delta}"
    );
}

#[test]
fn gradient_matches_central_finite_differences() {
    let fx = fixture();
    let shape = paper_shape();
    // A perturbed model (so that no gradient is trivially small) on 10 samples.
    let mut rng = stream(5, Purpose::ModelInit, 0);
    let w: Vec<f32> = fx
        .init
        .iter()
        .map(|v| v + (rng.normal() * 0.05) as f32)
        .collect();
    let n = 10;
    let data = TrainData::from_flat(
        &shape,
        fx.data.inputs[..n * shape.input_len()].to_vec(),
        fx.data.targets[..n * shape.outputs()].to_vec(),
    )
    .expect("sizes");
    let (grad, _) = gradient(&shape, &w, &data);
    // Per block of the layout: the weight with the largest gradient and a few others.
    let blocks = [
        (0, 128),
        (128, 1152),
        (1152, 1216),
        (1216, 2752),
        (2752, 2848),
    ];
    let mut picked = Vec::new();
    for (lo, hi) in blocks {
        let best = (lo..hi)
            .max_by(|&a, &b| grad[a].abs().total_cmp(&grad[b].abs()))
            .expect("block");
        picked.push(best);
        picked.extend((0..3).map(|_| lo + rng.below((hi - lo) as u64) as usize));
    }
    let g_max = grad.iter().map(|g| g.abs()).fold(0.0f32, f32::max);
    let step = 1e-2f32;
    let mut worst = 0.0f64;
    for &i in &picked {
        let mut plus = w.clone();
        plus[i] += step;
        let mut minus = w.clone();
        minus[i] -= step;
        let fd = (loss(&shape, &plus, &data) - loss(&shape, &minus, &data))
            / f64::from(plus[i] - minus[i]);
        let err =
            (fd - f64::from(grad[i])).abs() / f64::from(grad[i].abs()).max(0.05 * f64::from(g_max));
        worst = worst.max(err);
        assert!(
            err < 2e-2,
            "weight {i}: backprop {} vs finite difference {fd} ({err:e})",
            grad[i]
        );
    }
    eprintln!(
        "finite differences: largest relative error {worst:.3e} over {} weights",
        picked.len()
    );
}

#[test]
fn init_has_the_keras_layout_and_statistics() {
    let shape = ModelShape::from_config(&Config::default());
    assert_eq!(shape, paper_shape());
    assert_eq!(shape.weights(), 2848);
    let w = init_weights(&shape, &mut stream(9, Purpose::ModelInit, 0));
    assert_eq!(w.len(), 2848);
    let again = init_weights(&shape, &mut stream(9, Purpose::ModelInit, 0));
    assert_eq!(w, again);
    let (kernel, rec, bias, dense, dense_bias) = (
        &w[..128],
        &w[128..1152],
        &w[1152..1216],
        &w[1216..2752],
        &w[2752..],
    );
    // Bias: forget gate (units 16..32) one, the others zero.
    for (j, b) in bias.iter().enumerate() {
        assert_eq!(
            *b,
            if (16..32).contains(&j) { 1.0 } else { 0.0 },
            "bias {j}"
        );
    }
    assert!(dense_bias.iter().all(|b| *b == 0.0));
    // Glorot-uniform: bounded by sqrt(6 / (fan_in + fan_out)), variance limit^2 / 3.
    for (name, k, limit) in [
        ("kernel", kernel, (6.0f64 / 66.0).sqrt()),
        ("dense", dense, (6.0f64 / 112.0).sqrt()),
    ] {
        assert!(
            k.iter().all(|v| f64::from(v.abs()) <= limit),
            "{name} out of bounds"
        );
        let var = k.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / k.len() as f64;
        let want = limit * limit / 3.0;
        assert!(
            (var / want - 1.0).abs() < 0.25,
            "{name} variance {var} vs {want}"
        );
    }
    // Orthogonal recurrent kernel (16 x 64): orthonormal rows.
    for a in 0..16 {
        for b in 0..16 {
            let dot: f64 = (0..64)
                .map(|j| f64::from(rec[a * 64 + j]) * f64::from(rec[b * 64 + j]))
                .sum();
            let want = if a == b { 1.0 } else { 0.0 };
            assert!(
                (dot - want).abs() < 1e-5,
                "rows {a}, {b} of the recurrent kernel: {dot}"
            );
        }
    }
    // Different seeds, different models.
    assert_ne!(
        w,
        init_weights(&shape, &mut stream(10, Purpose::ModelInit, 0))
    );
}

fn small_jobs() -> Vec<TrainJob> {
    let fx = fixture();
    let shape = paper_shape();
    (0..4u32)
        .map(|robot| {
            let n = 20 + 5 * robot as usize;
            let data = TrainData::from_flat(
                &shape,
                fx.data.inputs[..n * shape.input_len()].to_vec(),
                fx.data.targets[..n * shape.outputs()].to_vec(),
            )
            .expect("sizes");
            TrainJob {
                shape: shape.clone(),
                cfg: learn_cfg(2, 0.01, 0.2, 0.8),
                start: fx.init.clone(),
                data,
                dropout: stream(1, Purpose::Dropout, robot),
            }
        })
        .collect()
}

fn bits(outcomes: &[TrainOutcome]) -> Vec<(Vec<u32>, u64, u64, u32)> {
    outcomes
        .iter()
        .map(|o| {
            let w = o.weights.iter().map(|v| v.to_bits()).collect();
            (
                w,
                o.val_loss.to_bits(),
                o.final_train_loss.to_bits(),
                o.train_samples,
            )
        })
        .collect()
}

#[test]
fn training_is_bit_identical_across_runs_threads_and_kernels() {
    let jobs = small_jobs();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| train_many(jobs.clone()))
    };
    let one = run(1);
    let four = run(4);
    assert_eq!(bits(&one), bits(&four), "1 vs 4 threads");
    // Sequentially, twice, and with each kernel variant.
    for kernel in [Kernel::Auto, Kernel::Baseline, Kernel::Avx2, Kernel::Avx512] {
        let seq: Vec<TrainOutcome> = jobs
            .iter()
            .map(|j| {
                train_with(
                    kernel,
                    &j.shape,
                    &j.cfg,
                    &j.start,
                    &j.data,
                    j.dropout.clone(),
                )
            })
            .collect();
        assert_eq!(bits(&one), bits(&seq), "kernel {kernel:?}");
    }
    // The training did something, and dropout masks came from the given stream.
    assert!(one[0].weights != jobs[0].start);
    assert!(one
        .iter()
        .all(|o| o.val_loss.is_finite() && o.final_train_loss.is_finite()));
    let j = &jobs[0];
    let other = train(
        &j.shape,
        &j.cfg,
        &j.start,
        &j.data,
        stream(2, Purpose::Dropout, 0),
    );
    assert_ne!(
        other.weights, one[0].weights,
        "the dropout stream must matter"
    );
    let mut no_drop = j.cfg.clone();
    no_drop.dropout = 0.0;
    let a = train(
        &j.shape,
        &no_drop,
        &j.start,
        &j.data,
        stream(2, Purpose::Dropout, 0),
    );
    let b = train(
        &j.shape,
        &no_drop,
        &j.start,
        &j.data,
        stream(3, Purpose::Dropout, 0),
    );
    assert_eq!(
        a.weights, b.weights,
        "without dropout the stream must not matter"
    );
    eprintln!(
        "kernels compared: auto = {}, avx2 = {}, avx512 = {}, baseline",
        Kernel::Auto.describe(),
        Kernel::Avx2.describe(),
        Kernel::Avx512.describe()
    );
}

#[test]
fn split_and_degenerate_inputs() {
    let check = |n: usize, frac: f64, expect: usize| {
        assert_eq!(split_point(n, frac), expect, "{n} x {frac}")
    };
    check(300, 0.8, 240);
    check(10, 0.8, 8);
    check(5, 0.8, 4);
    check(1, 0.8, 0);
    check(0, 0.8, 0);
    check(7, 1.0, 7);

    let fx = fixture();
    let shape = paper_shape();
    let cfg = learn_cfg(1, 0.01, 0.2, 0.8);
    let empty = TrainData::new(&shape, &[]).expect("empty is fine");
    let o = train(
        &shape,
        &cfg,
        &fx.init,
        &empty,
        stream(0, Purpose::Dropout, 0),
    );
    assert_eq!((o.train_samples, o.val_samples), (0, 0));
    assert_eq!(o.weights, fx.init);
    assert!(o.val_loss.is_nan() && o.final_train_loss.is_nan());
    assert!(loss(&shape, &fx.init, &empty).is_nan());

    // One sample: nothing to train on, one to validate.
    let one = TrainData::from_flat(
        &shape,
        fx.data.inputs[..shape.input_len()].to_vec(),
        fx.data.targets[..shape.outputs()].to_vec(),
    )
    .expect("sizes");
    let o = train(&shape, &cfg, &fx.init, &one, stream(0, Purpose::Dropout, 0));
    assert_eq!((o.train_samples, o.val_samples), (0, 1));
    assert_eq!(o.weights, fx.init);
    assert!(o.val_loss.is_finite());

    // NaN in the data: no panic, NaN comes out, and the fixed point refuses it.
    let mut inputs = fx.data.inputs[..5 * shape.input_len()].to_vec();
    inputs[3] = f32::NAN;
    let nan = TrainData::from_flat(
        &shape,
        inputs,
        fx.data.targets[..5 * shape.outputs()].to_vec(),
    )
    .expect("sizes");
    let o = train(&shape, &cfg, &fx.init, &nan, stream(0, Purpose::Dropout, 0));
    assert!(o.final_train_loss.is_nan());
    assert!(matches!(
        to_fixed(&o.weights, 1_000_000_000),
        Err(FixedPointError::NonFinite { .. })
    ));

    // Samples from the world: too short is an error naming the sample.
    let sample = |points: usize| Sample {
        time: crate::SimTime(0),
        points: vec![[0.5, -0.5]; points],
    };
    assert_eq!(
        TrainData::new(&shape, &[sample(100), sample(79)]),
        Err(LearnError::SampleTooShort {
            index: 1,
            points: 79,
            needed: 80
        })
    );
    let d = TrainData::new(&shape, &[sample(100), sample(80)]).expect("long enough");
    assert_eq!(d.len(), 2);
    assert!(TrainData::from_flat(&shape, vec![0.0; 63], vec![0.0; 96]).is_none());
}

#[test]
fn flop_count_is_stated_for_the_paper_model() {
    let shape = paper_shape();
    // Forward ~ 2 * 32 * 19 * 64 for the gates; backward about twice that.
    let f = shape.flops_per_eval_sample();
    let t = shape.flops_per_train_sample();
    assert!(f > 2 * 32 * 19 * 64 && f < 100_000, "{f}");
    assert!(2 * t > 5 * f && 2 * t < 7 * f, "{t} vs {f}");
    eprintln!("FLOP per sample pass: training {t}, evaluation {f}");
}

/// blake3 of the outcomes' weights and losses, as hex.
fn digest(outcomes: &[TrainOutcome]) -> String {
    let mut h = blake3::Hasher::new();
    for o in outcomes {
        for w in &o.weights {
            h.update(&w.to_le_bytes());
        }
        h.update(&o.val_loss.to_le_bytes());
        h.update(&o.final_train_loss.to_le_bytes());
        h.update(&o.train_samples.to_le_bytes());
    }
    h.finalize().to_hex().to_string()
}

/// Pins the bits of a few trainings (and of the Keras-default initialisation), so that a debug
/// build, a release build (`cargo test --release`) and a `-C target-cpu=x86-64-v3` build must
/// all agree with the same constant. A deliberate change of the arithmetic updates it.
#[test]
fn training_bits_are_pinned_across_builds() {
    let mut jobs = small_jobs();
    jobs[1].start = init_weights(&paper_shape(), &mut stream(4, Purpose::ModelInit, 0));
    let outcomes: Vec<TrainOutcome> = jobs
        .iter()
        .map(|j| {
            train_with(
                Kernel::Baseline,
                &j.shape,
                &j.cfg,
                &j.start,
                &j.data,
                j.dropout.clone(),
            )
        })
        .collect();
    let got = digest(&outcomes);
    eprintln!("pinned training digest: {got}");
    assert_eq!(got, PINNED_TRAINING_DIGEST);
    assert_eq!(
        digest(&train_many(jobs)),
        got,
        "dispatched kernels agree with the pin"
    );
}

const PINNED_TRAINING_DIGEST: &str =
    "fdc30e2970a74c42304dbe2d6440af92f0bf1cf71372d6403bd41a1804201096";

//! Tests of the learning module against TensorFlow/Keras, finite differences, and itself.

// The reference loops index several arrays at the same position; iterators would hide that.
#![allow(clippy::needless_range_loop)]
use super::*;
use crate::rng::{stream, Purpose};

fn paper_shape() -> ModelShape {
    ModelShape {
        units: 16,
        input_steps: 32,
        output_steps: 48,
        frame: Frame::World,
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
    let data = fx.data.head(n);
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
            let data = fx.data.head(n);
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
fn spawned_trainings_give_the_outcomes_of_train_many() {
    let jobs = small_jobs();
    let expected = bits(&train_many(jobs.clone()));
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        // Started from inside the pool (as a driver running on it) and from outside it.
        let inside: Vec<TrainOutcome> = pool.install(|| {
            let spawned: Vec<Spawned> = jobs.iter().cloned().map(Spawned::start).collect();
            spawned.into_iter().map(Spawned::wait).collect()
        });
        assert_eq!(bits(&inside), expected, "{threads} pool threads");
    }
    // From outside any pool (rayon's global one), waited for in reverse order; every other one
    // is dropped instead (cancelled if not started, thrown away if it was).
    let mut spawned: Vec<Option<Spawned>> =
        jobs.iter().cloned().map(Spawned::start).map(Some).collect();
    let mut waited: Vec<Option<TrainOutcome>> = (0..jobs.len()).map(|_| None).collect();
    for i in (0..jobs.len()).rev() {
        let handle = spawned[i].take();
        if i % 2 == 0 {
            waited[i] = handle.map(Spawned::wait);
        }
    }
    let kept: Vec<TrainOutcome> = train_many(jobs).into_iter().step_by(2).collect();
    let waited: Vec<TrainOutcome> = waited.into_iter().flatten().collect();
    assert_eq!(
        bits(&waited),
        bits(&kept),
        "global pool, reverse order, some dropped"
    );
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
    // Sequentially, twice, and with each kernel variant; each on the thread choice `train`
    // makes, with the groups of each batch on two threads (`pair.rs`), and forced onto one.
    for kernel in [Kernel::Auto, Kernel::Baseline, Kernel::Avx2, Kernel::Avx512] {
        for threads in [Threads::Auto, Threads::One, Threads::Two] {
            let seq: Vec<TrainOutcome> = jobs
                .iter()
                .map(|j| {
                    train_threads(
                        kernel,
                        threads,
                        &j.shape,
                        &j.cfg,
                        &j.start,
                        &j.data,
                        j.dropout.clone(),
                    )
                })
                .collect();
            assert_eq!(
                bits(&one),
                bits(&seq),
                "kernel {kernel:?}, threads {threads:?}"
            );
        }
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

/// Batches of more groups than threads (45 samples: groups of 10, 10, 10, 10 and 5), so that in
/// `pair.rs` each thread adds several groups into the batch gradient and waits its turn for
/// each: two threads give the bits of one, on every kernel, every time.
#[test]
fn batches_of_many_groups_give_the_same_bits_on_two_threads() {
    let fx = fixture();
    let shape = paper_shape();
    let mut cfg = learn_cfg(3, 0.01, 0.2, 0.8);
    cfg.batch_size = 45;
    let data = fx.data.head(120);
    let dropout = stream(5, Purpose::Dropout, 0);
    let run = |kernel: Kernel, threads: Threads| {
        let o = train_threads(
            kernel,
            threads,
            &shape,
            &cfg,
            &fx.init,
            &data,
            dropout.clone(),
        );
        bits(&[o])
    };
    let one = run(Kernel::Baseline, Threads::One);
    for kernel in [Kernel::Baseline, Kernel::Avx2, Kernel::Avx512] {
        for repeat in 0..3 {
            assert_eq!(
                run(kernel, Threads::Two),
                one,
                "kernel {kernel:?}, two threads, repeat {repeat}"
            );
        }
    }
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
    let one = fx.data.head(1);
    let o = train(&shape, &cfg, &fx.init, &one, stream(0, Purpose::Dropout, 0));
    assert_eq!((o.train_samples, o.val_samples), (0, 1));
    assert_eq!(o.weights, fx.init);
    assert!(o.val_loss.is_finite());

    // NaN in the data: no panic, NaN comes out, and the fixed point refuses it.
    let mut nan = fx.data.head(5);
    nan.inputs[[0, 1, 1]] = f32::NAN;
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
fn the_relative_frame_subtracts_the_last_input_waypoint_and_ignores_where_the_arena_is() {
    let shape = ModelShape {
        units: 2,
        input_steps: 3,
        output_steps: 2,
        frame: Frame::Relative,
    };
    let walk = |dx: f32, dy: f32| Sample {
        time: crate::SimTime(0),
        points: (0..6)
            .map(|k| [dx + 0.25 * k as f32, dy - 0.5 * k as f32])
            .collect(),
    };
    // Waypoint 2 (the last input) is the origin: inputs -0.5, -0.25, 0 in x; targets +0.25,
    // +0.5 in x and -0.5, -1 in y. Waypoint 5 is beyond input + target and unused.
    let d = TrainData::new(&shape, &[walk(1.0, 2.0)]).unwrap();
    let inputs: Vec<f32> = d.inputs.iter().copied().collect();
    assert_eq!(inputs, [-0.5, 1.0, -0.25, 0.5, 0.0, 0.0]);
    assert_eq!(d.target(0), [0.25, -0.5, 0.5, -1.0]);
    // The same walk 20 m away is the same data set (the offsets are exact in f32).
    assert_eq!(TrainData::new(&shape, &[walk(21.0, -18.0)]).unwrap(), d);
    // The paper's world frame keeps the coordinates and tells the two apart.
    let world = ModelShape {
        frame: Frame::World,
        ..shape
    };
    let far = TrainData::new(&world, &[walk(21.0, -18.0)]).unwrap();
    assert_ne!(far, TrainData::new(&world, &[walk(1.0, 2.0)]).unwrap());
    assert_eq!(far.target(0), [21.75, -19.5, 22.0, -20.0]);
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
    "269b67090957ecd321981cb6ccb9d70a6180fe9a197ca693eb696abd8c85e924";

/// Random values for the equivalence tests: normal, with exact zeros and negative zeros mixed
/// in (so that `0 + (-0)` and `0 * w` cases are exercised).
fn random_values(rng: &mut Rng, n: usize, scale: f64) -> Vec<f32> {
    (0..n)
        .map(|_| match rng.below(10) {
            0 => 0.0,
            1 => -0.0,
            _ => (rng.normal() * scale) as f32,
        })
        .collect()
}

fn to_bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The register-blocked products equal the plain per-sample loops bit for bit, for every tile
/// shape, on random sizes whose sample counts and widths are not multiples of the tiles.
#[test]
fn blocked_products_equal_the_per_sample_order() {
    use super::kernels::{outer_acc, rows_acc};
    let mut rng = stream(11, Purpose::ModelInit, 1);
    type Rows = fn(&mut [f32], &[f32], &[f32], usize);
    type Outer = fn(&mut [f32], &[f32], &[f32], usize, usize, usize);
    #[allow(unused_mut)]
    let mut tiles: Vec<(&str, Rows, Outer)> = vec![
        ("1x1", rows_acc::<1, 1>, outer_acc::<1, 1>),
        ("4x8", rows_acc::<4, 8>, outer_acc::<4, 8>),
        ("4x16", rows_acc::<4, 16>, outer_acc::<4, 16>),
        ("4x64", rows_acc::<4, 64>, outer_acc::<4, 64>),
        ("3x32", rows_acc::<3, 32>, outer_acc::<3, 32>),
        ("8x16", rows_acc::<8, 16>, outer_acc::<8, 16>),
    ];
    #[cfg(target_arch = "x86_64")]
    {
        use super::kernels::Mat;
        use super::simd::{Avx2, Avx512};
        #[target_feature(enable = "avx512f")]
        unsafe fn rows_512(o: &mut [f32], a: &[f32], m: &[f32], n: usize) {
            // SAFETY: this function requires AVX-512F.
            unsafe { Avx512::rows_acc(o, a, m, n) }
        }
        #[target_feature(enable = "avx512f")]
        unsafe fn outer_512(g: &mut [f32], a: &[f32], d: &[f32], t: usize, gr: usize, s: usize) {
            // SAFETY: this function requires AVX-512F.
            unsafe { Avx512::outer_acc(g, a, d, t, gr, s) }
        }
        #[target_feature(enable = "avx2")]
        unsafe fn rows_256(o: &mut [f32], a: &[f32], m: &[f32], n: usize) {
            // SAFETY: this function requires AVX2.
            unsafe { Avx2::rows_acc(o, a, m, n) }
        }
        #[target_feature(enable = "avx2")]
        unsafe fn outer_256(g: &mut [f32], a: &[f32], d: &[f32], t: usize, gr: usize, s: usize) {
            // SAFETY: this function requires AVX2.
            unsafe { Avx2::outer_acc(g, a, d, t, gr, s) }
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F (checked on the line above).
            tiles.push((
                "avx512",
                |o, a, m, n| unsafe { rows_512(o, a, m, n) },
                |g, a, d, t, gr, s| unsafe { outer_512(g, a, d, t, gr, s) },
            ));
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked on the line above).
            tiles.push((
                "avx2",
                |o, a, m, n| unsafe { rows_256(o, a, m, n) },
                |g, a, d, t, gr, s| unsafe { outer_256(g, a, d, t, gr, s) },
            ));
        }
    }
    for case in 0..40 {
        let samples = 1 + rng.below(11) as usize;
        let group = samples + rng.below(3) as usize;
        let k = 1 + rng.below(40) as usize;
        let n = 1 + rng.below(150) as usize;
        let steps = 1 + rng.below(5) as usize;
        // rows_acc: out[s][j] += sum over kk ascending of a[s][kk] m[kk][j].
        let a = random_values(&mut rng, samples * k, 1.0);
        let m = random_values(&mut rng, k * n, 1.0);
        let init = random_values(&mut rng, samples * n, 1.0);
        let mut want = init.clone();
        for s in 0..samples {
            for j in 0..n {
                let mut acc = want[s * n + j];
                for kk in 0..k {
                    acc += a[s * k + kk] * m[kk * n + j];
                }
                want[s * n + j] = acc;
            }
        }
        // outer_acc: per sample in order, grad[r][j] += (0 + sum over t of a[t][s][r] d[t][s][j]).
        let oa = random_values(&mut rng, steps * group * k, 1.0);
        let od = random_values(&mut rng, steps * group * n, 1.0);
        let grad0 = random_values(&mut rng, k * n, 1.0);
        let mut want_grad = grad0.clone();
        for s in 0..samples {
            for r in 0..k {
                for j in 0..n {
                    let mut p = 0.0f32;
                    for t in 0..steps {
                        p += oa[(t * group + s) * k + r] * od[(t * group + s) * n + j];
                    }
                    want_grad[r * n + j] += p;
                }
            }
        }
        for &(name, rows, outer) in &tiles {
            let mut got = init.clone();
            rows(&mut got, &a, &m, n);
            assert_eq!(
                to_bits(&got),
                to_bits(&want),
                "rows_acc {name}, case {case}: {samples} samples, k {k}, n {n}"
            );
            let mut got = grad0.clone();
            outer(&mut got, &oa, &od, steps, group, samples);
            assert_eq!(
                to_bits(&got),
                to_bits(&want_grad),
                "outer_acc {name}, case {case}: {samples} of {group} samples, {k} x {n}, {steps} steps"
            );
        }
    }
}

/// What a plain forward pass keeps for its backward pass (one sample).
struct RefPass {
    xh: Vec<Vec<f32>>,
    gates: Vec<Vec<f32>>,
    cs: Vec<Vec<f32>>,
    tanh_c: Vec<Vec<f32>>,
    hd1: Vec<f32>,
    y: Vec<f32>,
}

/// The unblocked forward pass of one sample, in the orders of the kernels' documentation,
/// with the scalar activations of [`math`].
fn ref_forward(shape: &ModelShape, w: &[f32], x: &[f32], mask: &[f32]) -> RefPass {
    let (t_n, d, h, g, r1, o) = (
        shape.steps_in(),
        shape.input_dims(),
        shape.units(),
        shape.gates(),
        shape.rows_lstm(),
        shape.outputs(),
    );
    let mut pass = RefPass {
        xh: Vec::new(),
        gates: Vec::new(),
        cs: vec![vec![0.0; h]],
        tanh_c: Vec::new(),
        hd1: Vec::new(),
        y: vec![0.0; o],
    };
    let mut h_prev = vec![0.0f32; h];
    for t in 0..t_n {
        let mut xh = x[t * d..(t + 1) * d].to_vec();
        xh.extend(&h_prev);
        xh.push(1.0);
        let mut z = vec![0.0f32; g];
        for j in 0..g {
            for k in 0..r1 {
                z[j] += xh[k] * w[k * g + j];
            }
        }
        for j in 0..g {
            z[j] = if (2 * h..3 * h).contains(&j) {
                math::tanh_lane(z[j])
            } else {
                math::sigmoid_lane(z[j])
            };
        }
        let c_prev = &pass.cs[t];
        let c: Vec<f32> = (0..h)
            .map(|u| z[h + u] * c_prev[u] + z[u] * z[2 * h + u])
            .collect();
        let tc: Vec<f32> = c.iter().map(|v| math::tanh_lane(*v)).collect();
        h_prev = (0..h).map(|u| z[3 * h + u] * tc[u]).collect();
        pass.xh.push(xh);
        pass.gates.push(z);
        pass.cs.push(c);
        pass.tanh_c.push(tc);
    }
    pass.hd1 = (0..h).map(|u| h_prev[u] * mask[u]).collect();
    pass.hd1.push(1.0);
    let dense = &w[shape.dense_offset()..];
    for j in 0..o {
        for k in 0..=h {
            pass.y[j] += pass.hd1[k] * dense[k * o + j];
        }
    }
    pass
}

/// The unblocked backward pass of one sample: adds its gradient into `grad`.
fn ref_backward(
    shape: &ModelShape,
    w: &[f32],
    pass: &RefPass,
    dy: &[f32],
    mask: &[f32],
    grad: &mut [f32],
) {
    let (t_n, d, h, g, r1, o) = (
        shape.steps_in(),
        shape.input_dims(),
        shape.units(),
        shape.gates(),
        shape.rows_lstm(),
        shape.outputs(),
    );
    let off = shape.dense_offset();
    for k in 0..=h {
        for j in 0..o {
            let p = 0.0f32 + pass.hd1[k] * dy[j];
            grad[off + k * o + j] += p;
        }
    }
    let mut dh = vec![0.0f32; h];
    for u in 0..h {
        for j in 0..o {
            dh[u] += dy[j] * w[off + u * o + j];
        }
        dh[u] *= mask[u];
    }
    let mut dc = vec![0.0f32; h];
    let mut dz = vec![vec![0.0f32; g]; t_n];
    for t in (0..t_n).rev() {
        let z = &pass.gates[t];
        let tc = &pass.tanh_c[t];
        for u in 0..h {
            let (i, f, gg, oo) = (z[u], z[h + u], z[2 * h + u], z[3 * h + u]);
            let d_o = dh[u] * tc[u];
            let dcu = dc[u] + dh[u] * oo * (1.0 - tc[u] * tc[u]);
            dz[t][u] = dcu * gg * (i * (1.0 - i));
            dz[t][h + u] = dcu * pass.cs[t][u] * (f * (1.0 - f));
            dz[t][2 * h + u] = dcu * i * (1.0 - gg * gg);
            dz[t][3 * h + u] = d_o * (oo * (1.0 - oo));
            dc[u] = dcu * f;
        }
        if t > 0 {
            for u in 0..h {
                dh[u] = 0.0;
                for j in 0..g {
                    dh[u] += dz[t][j] * w[(d + u) * g + j];
                }
            }
        }
    }
    for r in 0..r1 {
        for j in 0..g {
            let mut p = 0.0f32;
            for t in 0..t_n {
                p += pass.xh[t][r] * dz[t][j];
            }
            grad[r * g + j] += p;
        }
    }
}

/// The plain trainer the blocked kernels replaced: one sample at a time, scalar loops.
fn ref_train(
    shape: &ModelShape,
    cfg: &LearnConfig,
    start: &[f32],
    data: &TrainData,
    mut dropout: Rng,
) -> TrainOutcome {
    let (h, o) = (shape.units(), shape.outputs());
    let input = |i: usize| data.inputs.slice(ndarray::s![i, .., ..]).to_owned();
    let n_train = split_point(data.len(), cfg.train_fraction);
    let (lr, p) = (cfg.learning_rate as f32, cfg.dropout as f32);
    let keep_scale = 1.0f32 / (1.0f32 - p);
    let mut w = start.to_vec();
    let mut final_train_loss = f64::NAN;
    if n_train > 0 && cfg.epochs > 0 && cfg.batch_size > 0 {
        let batch = cfg.batch_size as usize;
        for _ in 0..cfg.epochs {
            let mut sse = 0.0f64;
            for start in (0..n_train).step_by(batch) {
                let end = (start + batch).min(n_train);
                let scale = 2.0f32 / ((end - start) * o) as f32;
                let mut grad = vec![0.0f32; w.len()];
                for i in start..end {
                    let mask: Vec<f32> = (0..h)
                        .map(|_| {
                            if dropout.uniform_f32() >= p {
                                keep_scale
                            } else {
                                0.0
                            }
                        })
                        .collect();
                    let x = input(i);
                    let pass = ref_forward(shape, &w, x.as_slice().expect("owned"), &mask);
                    let target = data.target(i);
                    let mut dy = vec![0.0f32; o];
                    // Each sample's squared errors are summed first, then added to the total.
                    let mut sample_sse = 0.0f64;
                    for j in 0..o {
                        let e = pass.y[j] - target[j];
                        sample_sse += f64::from(e) * f64::from(e);
                        dy[j] = e * scale;
                    }
                    sse += sample_sse;
                    ref_backward(shape, &w, &pass, &dy, &mask, &mut grad);
                }
                for (wk, gk) in w.iter_mut().zip(&grad) {
                    *wk -= *gk * lr;
                }
            }
            final_train_loss = sse / (n_train * o) as f64;
        }
    }
    let n_val = data.len() - n_train;
    let mut val_sse = 0.0f64;
    for i in n_train..data.len() {
        let x = input(i);
        let pass = ref_forward(shape, &w, x.as_slice().expect("owned"), &vec![1.0; h]);
        let mut sample_sse = 0.0f64;
        for (y, t) in pass.y.iter().zip(data.target(i)) {
            let e = y - t;
            sample_sse += f64::from(e) * f64::from(e);
        }
        val_sse += sample_sse;
    }
    TrainOutcome {
        weights: w,
        train_samples: n_train as u32,
        val_samples: n_val as u32,
        val_loss: if n_val > 0 {
            val_sse / (n_val * o) as f64
        } else {
            f64::NAN
        },
        final_train_loss,
    }
}

/// Whole trainings with the blocked kernels (every compiled variant) equal the plain
/// per-sample trainer bit for bit, on random model shapes, sample counts and batch sizes that
/// are not multiples of the group or the tile (remainder groups and tiles).
#[test]
fn blocked_training_equals_the_per_sample_trainer() {
    let mut rng = stream(12, Purpose::ModelInit, 2);
    for case in 0..10 {
        let shape = ModelShape {
            units: 1 + rng.below(20) as u32,
            input_steps: 1 + rng.below(6) as u32,
            output_steps: 1 + rng.below(9) as u32,
            frame: Frame::World,
        };
        let samples = 1 + rng.below(30) as usize;
        let inputs = random_values(&mut rng, samples * shape.input_len(), 1.0);
        let targets = random_values(&mut rng, samples * shape.outputs(), 1.0);
        let data = TrainData::from_flat(&shape, inputs, targets).expect("sizes");
        let start = random_values(&mut rng, shape.weights(), 0.4);
        let mut cfg = learn_cfg(2, 0.05, 0.3, 0.8);
        cfg.batch_size = 1 + rng.below(13) as u32;
        let dropout = stream(case as u64, Purpose::Dropout, 0);
        let want = ref_train(&shape, &cfg, &start, &data, dropout.clone());
        assert!(want.weights.iter().all(|w| w.is_finite()));
        for kernel in [Kernel::Baseline, Kernel::Avx2, Kernel::Avx512] {
            for threads in [Threads::Auto, Threads::One, Threads::Two] {
                let got = train_threads(
                    kernel,
                    threads,
                    &shape,
                    &cfg,
                    &start,
                    &data,
                    dropout.clone(),
                );
                assert_eq!(
                    bits(&[got]),
                    bits(std::slice::from_ref(&want)),
                    "case {case}: {shape:?}, {samples} samples, batch {}, kernel {kernel:?}, \
                     threads {threads:?}",
                    cfg.batch_size
                );
            }
        }
        let grad = gradient(&shape, &start, &data).0;
        let pass_grad = {
            let mut grad = vec![0.0f32; shape.weights()];
            let scale = 2.0f32 / (samples * shape.outputs()) as f32;
            for i in 0..samples {
                let x = data.inputs.slice(ndarray::s![i, .., ..]).to_owned();
                let ones = vec![1.0; shape.units()];
                let pass = ref_forward(&shape, &start, x.as_slice().expect("owned"), &ones);
                let dy: Vec<f32> = pass
                    .y
                    .iter()
                    .zip(data.target(i))
                    .map(|(y, t)| (y - t) * scale)
                    .collect();
                ref_backward(&shape, &start, &pass, &dy, &ones, &mut grad);
            }
            grad
        };
        assert_eq!(to_bits(&grad), to_bits(&pass_grad), "gradient, case {case}");
    }
}

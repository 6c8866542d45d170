//! `swarmfl bench train`: one local training of the reference workload (issue: learning).
//!
//! Workload: 300 samples of 80 waypoints (240 train, 60 validate), the paper's model, 20 epochs
//! of SGD in batches of 20 with the `reference` preset's learning rate, dropout 0.2; then the
//! validation loss. One training on two threads when rayon's pool has two (`learn/pair.rs`:
//! the groups of each batch side by side, same bits), and the same on one thread for
//! comparison; CPU times are the calling thread's. Timed over [`REPETITIONS`] runs; the median
//! is reported. The FLOP count counts every add and multiply
//! of the forward and backward passes (and each sigmoid/tanh as one), see
//! `ModelShape::flops_per_train_sample`.

use std::time::Instant;

use swarmfl_core::config::Preset;
use swarmfl_core::data::Sample;
use swarmfl_core::learn::{self, Kernel, ModelShape, Threads, TrainData};
use swarmfl_core::rng::{stream, Purpose};
use swarmfl_core::world::{Controllers, World};

/// Timed repetitions of the training.
const REPETITIONS: usize = 15;
/// Samples in the workload (80 % train, 20 % validate).
const SAMPLES: usize = 300;

/// REAL simulated trajectories: the `reference` preset's world (seed 2026) is simulated until a
/// robot's data set holds [`SAMPLES`] samples; its oldest [`SAMPLES`] are the workload (what that
/// robot would train on then). Deterministic: the same samples every time.
pub fn bench_workload() -> anyhow::Result<Vec<Sample>> {
    let config = Preset::Reference.config();
    let seed = 2026;
    let mut world = World::new(&config, seed)?;
    let mut controllers = Controllers::new(&config, seed);
    for _ in 0..config.ticks() {
        world.apply(&controllers.decide(&world));
        if let Some(robot) = (0..config.world.robots).find(|&r| world.dataset_len(r) >= SAMPLES) {
            let mut samples = world.dataset(robot);
            samples.truncate(SAMPLES);
            return Ok(samples);
        }
    }
    anyhow::bail!("no robot collected {SAMPLES} samples in a reference run")
}

/// CPU time of the calling thread in milliseconds (immune to other processes sharing the
/// cores, unlike wall time).
fn thread_cpu_ms() -> f64 {
    swarmfl_study::run::thread_cpu_s() * 1e3
}

/// Median wall time, median thread CPU time (ms) and the validation loss of the last run.
fn median_ms(
    kernel: Kernel,
    threads: Threads,
    shape: &ModelShape,
    data: &TrainData,
    start: &[f32],
) -> (f64, f64, f64) {
    let cfg = Preset::Reference.config().learn;
    let mut wall = Vec::with_capacity(REPETITIONS);
    let mut cpu = Vec::with_capacity(REPETITIONS);
    let mut val_loss = f64::NAN;
    for rep in 0..REPETITIONS {
        let dropout = stream(1, Purpose::Dropout, rep as u32);
        let (t0, c0) = (Instant::now(), thread_cpu_ms());
        let out = learn::train_threads(kernel, threads, shape, &cfg, start, data, dropout);
        cpu.push(thread_cpu_ms() - c0);
        wall.push(t0.elapsed().as_secs_f64() * 1e3);
        val_loss = out.val_loss;
        assert_eq!((out.train_samples, out.val_samples), (240, 60));
    }
    wall.sort_by(f64::total_cmp);
    cpu.sort_by(f64::total_cmp);
    (wall[REPETITIONS / 2], cpu[REPETITIONS / 2], val_loss)
}

/// Runs the training benchmark and prints its figures (JSON with `json`).
pub fn run(json: bool) -> anyhow::Result<()> {
    let config = Preset::Reference.config();
    let shape = ModelShape::from_config(&config);
    let data = TrainData::new(&shape, &bench_workload()?)?;
    let start = learn::init_weights(&shape, &mut stream(1, Purpose::ModelInit, 0));
    let cfg = &config.learn;
    let n_train = learn::split_point(data.len(), cfg.train_fraction) as u64;
    let n_val = data.len() as u64 - n_train;
    let train_passes = n_train * u64::from(cfg.epochs);
    let flop_train = shape.flops_per_train_sample();
    let flop_eval = shape.flops_per_eval_sample();
    let total_flop = train_passes * flop_train + n_val * flop_eval;

    let (auto_ms, auto_cpu_ms, val_loss) =
        median_ms(Kernel::Auto, Threads::Auto, &shape, &data, &start);
    let (one_ms, one_cpu_ms, one_val_loss) =
        median_ms(Kernel::Auto, Threads::One, &shape, &data, &start);
    anyhow::ensure!(
        one_val_loss.to_bits() == val_loss.to_bits(),
        "one thread and two gave different validation losses ({one_val_loss} and {val_loss}): \
         a determinism bug, please report it"
    );
    let (avx2_ms, avx2_cpu_ms, _) = median_ms(Kernel::Avx2, Threads::Auto, &shape, &data, &start);
    let (base_ms, base_cpu_ms, _) =
        median_ms(Kernel::Baseline, Threads::Auto, &shape, &data, &start);
    let passes_per_s = (train_passes + n_val) as f64 / (auto_ms / 1e3);
    let gflops = total_flop as f64 / (auto_ms / 1e3) / 1e9;
    let base_gflops = total_flop as f64 / (base_ms / 1e3) / 1e9;
    let report = serde_json::json!({
        "workload": "real simulated trajectories (reference preset world, seed 2026: the first robot to hold 300 samples), 240 train + 60 validation samples, 20 epochs, batch 20",
        "learning_rate": cfg.learning_rate,
        "repetitions": REPETITIONS,
        "threads": rayon::current_num_threads().min(2),
        "kernel": format!("{} (run-time dispatch)", Kernel::Auto.describe()),
        "local_training_median_ms": auto_ms,
        "local_training_median_cpu_ms": auto_cpu_ms,
        "one_thread_median_ms": one_ms,
        "one_thread_median_cpu_ms": one_cpu_ms,
        "avx2_kernel": Kernel::Avx2.describe(),
        "avx2_kernel_median_ms": avx2_ms,
        "avx2_kernel_median_cpu_ms": avx2_cpu_ms,
        "baseline_kernel_median_ms": base_ms,
        "baseline_kernel_median_cpu_ms": base_cpu_ms,
        "sample_passes_per_s": passes_per_s,
        "flop_per_train_sample_pass": flop_train,
        "flop_per_eval_sample_pass": flop_eval,
        "gflop_per_s": gflops,
        "gflop_per_s_cpu_time": total_flop as f64 / (auto_cpu_ms / 1e3) / 1e9,
        "flop_per_training": total_flop,
        "baseline_kernel_gflop_per_s": base_gflops,
        "val_loss": val_loss,
    });
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "local training (240 + 60 samples, 20 epochs, batch 20), {} thread(s), {REPETITIONS} runs",
            report["threads"]
        );
        println!(
            "  median            {auto_ms:.1} ms wall, {auto_cpu_ms:.1} ms CPU of this thread ({})",
            report["kernel"].as_str().unwrap_or("")
        );
        println!("  one thread        {one_ms:.1} ms wall, {one_cpu_ms:.1} ms CPU");
        println!("  avx2 kernel       {avx2_ms:.1} ms wall, {avx2_cpu_ms:.1} ms CPU");
        println!("  baseline kernel   {base_ms:.1} ms wall, {base_cpu_ms:.1} ms CPU");
        println!("  sample passes/s   {passes_per_s:.0}");
        println!("  GFLOP/s           {gflops:.2} (baseline {base_gflops:.2}); {flop_train} FLOP per training sample pass");
        println!("  validation loss   {val_loss:.6}");
    }
    Ok(())
}

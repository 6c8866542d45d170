#!/usr/bin/env python3
"""Times the `swarmfl bench train` workload in TensorFlow/Keras, for a side-by-side figure.

Workload (identical sizes and hyper-parameters to replay-cli/src/commands/bench/train.rs): the paper's
model (LSTM(16) -> Dropout(0.2) -> Dense(96) -> Reshape(48, 2)), 300 synthetic trajectories of
80 waypoints (a robot at 0.025 m/s, tick 0.1 s, random turns, 5 x 5 m arena), the first 240 to
train and the last 60 to validate, model.fit(batch_size=20, epochs=20, shuffle=False) with SGD
at the reference learning rate 0.01, then model.evaluate on the 60. The trajectories come from
numpy, not from swarmfl's generator; the time does not depend on the values.

One warm-up run (graph tracing) is excluded; the median over the timed repetitions is
printed, as wall time and as process CPU time. TensorFlow uses its default thread pools (all
cores), as the paper's setup did; set KERAS_PEER_THREADS=1 to pin it to one thread.

Usage: pip install tensorflow-cpu && python3 bench/keras_peer.py [repetitions]
"""
import json
import os
import statistics
import sys
import time

os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
import numpy as np
import tensorflow as tf
import keras

threads = os.environ.get("KERAS_PEER_THREADS")
if threads:
    tf.config.threading.set_intra_op_parallelism_threads(int(threads))
    tf.config.threading.set_inter_op_parallelism_threads(int(threads))

SAMPLES, T_IN, T_OUT, UNITS, EPOCHS, BATCH, LR = 300, 32, 48, 16, 20, 20, 0.01


def workload(seed=2026):
    rng = np.random.default_rng(seed)
    speed, tick, half = 0.025, 0.1, 2.5 - 0.035
    out = np.zeros((SAMPLES, 80, 2), dtype=np.float32)
    for s in range(SAMPLES):
        x, y = rng.uniform(-half, half, size=2)
        heading = rng.uniform(-np.pi, np.pi)
        turn_left, turn_rate = 0.0, 0.0
        for t in range(80):
            out[s, t] = (x, y)
            if turn_left <= 0 and rng.random() < 0.1 * tick:
                turn_left, turn_rate = rng.uniform(0, 3), rng.uniform(-1, 1)
            if turn_left > 0:
                heading += turn_rate * tick
                turn_left -= tick
            x += speed * tick * np.cos(heading)
            y += speed * tick * np.sin(heading)
            if abs(x) > half:
                x, heading = np.clip(x, -half, half), np.pi - heading
            if abs(y) > half:
                y, heading = np.clip(y, -half, half), -heading
    return out


def main():
    reps = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    data = workload()
    x, y = data[:, :T_IN], data[:, T_IN:T_IN + T_OUT]
    n_train = int(np.floor(SAMPLES * 0.8))
    keras.utils.set_random_seed(1)
    model = keras.Sequential([
        keras.Input(shape=(T_IN, 2)),
        keras.layers.LSTM(UNITS),
        keras.layers.Dropout(0.2),
        keras.layers.Dense(T_OUT * 2),
        keras.layers.Reshape((T_OUT, 2)),
    ])
    model.compile(optimizer=keras.optimizers.SGD(learning_rate=LR), loss="mse")
    init = model.get_weights()
    wall, cpu = [], []
    for rep in range(reps + 1):
        model.set_weights(init)
        t0, c0 = time.perf_counter(), time.process_time()
        model.fit(x[:n_train], y[:n_train], batch_size=BATCH, epochs=EPOCHS, shuffle=False, verbose=0)
        val_loss = model.evaluate(x[n_train:], y[n_train:], batch_size=BATCH, verbose=0)
        if rep > 0:
            wall.append((time.perf_counter() - t0) * 1e3)
            cpu.append((time.process_time() - c0) * 1e3)
    print(json.dumps({
        "framework": f"tensorflow {tf.__version__}, keras {keras.__version__}",
        "threads": threads or "default",
        "repetitions": reps,
        "keras_local_training_median_ms": statistics.median(wall),
        "keras_local_training_median_cpu_ms": statistics.median(cpu),
        "all_wall_ms": [round(v, 1) for v in wall],
        "val_loss": float(val_loss),
    }, indent=2))


if __name__ == "__main__":
    main()

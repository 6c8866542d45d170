"""The overhead of a Python plug-in attack (issue 34): the smoke preset with 3 Byzantine robots
under a built-in attack and under its numpy twin (`swarmfl.Attack`), 5 runs of each,
interleaved; prints the median wall time of each, the difference per run and per call of the
plug-in, and checks that both give the same rounds, submissions and balances.

    pip install ./python
    nice -n 19 python bench/plugin_overhead.py [--runs 5] [--duration 600]
"""

import argparse
import statistics
import tempfile
import time

import numpy as np

import swarmfl


class PySignFlip(swarmfl.Attack):
    """byzantine/sign_flip.rs in numpy."""

    def act(self, view):
        if view.previous is None:
            return view.shared, view.claimed_samples
        w, p = view.shared.astype(np.float64), view.previous.astype(np.float64)
        return (w - view.config["scale"] * (w - p)).astype(np.float32), view.claimed_samples


class PyMalicious(swarmfl.Attack):
    """byzantine/malicious.rs: resubmit w(t)."""

    def act(self, view):
        return view.shared, view.claimed_samples


class Counting:
    """Wraps an attack to count its calls (a class of its own so its source digest is stable)."""

    def __init__(self, inner):
        self.inner, self.calls, self.name = inner, 0, type(inner).__name__

    def act(self, view):
        self.calls += 1
        return self.inner.act(view)


p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
p.add_argument("--runs", type=int, default=5)
p.add_argument("--duration", type=float, default=600.0, help="simulated seconds (smoke: 600)")
args = p.parse_args()
base = {"run.duration_s": args.duration, "byzantine.count": 3, "byzantine.scale": 2.0}
print(f"smoke preset, {args.duration:g} s, 3 Byzantine robots of 15, {args.runs} runs each, "
      "interleaved; wall time of swarmfl.run (median)")
print(f"{'attack':<12} {'built-in s':>10} {'python s':>10} {'overhead':>9} {'calls':>6} {'per call':>9}")
for builtin, cls in [("sign-flip", PySignFlip), ("malicious", PyMalicious)]:
    walls = {"builtin": [], "python": []}
    calls = 0
    for i in range(args.runs):
        with tempfile.TemporaryDirectory() as d:
            t = time.perf_counter()
            a = swarmfl.run(preset="smoke", seed=7, out=f"{d}/b", set={**base, "byzantine.kind": builtin})
            walls["builtin"].append(time.perf_counter() - t)
            attack = Counting(cls())
            t = time.perf_counter()
            b = swarmfl.run(preset="smoke", seed=7, out=f"{d}/p", set=base, attack=attack)
            walls["python"].append(time.perf_counter() - t)
            calls = attack.calls
            if i == 0:
                for table in ["rounds", "submissions", "balances"]:
                    x, y = getattr(a, table), getattr(b, table)
                    assert x.equals(y), f"{builtin}: the plug-in's {table} differ from the built-in's"
    mb, mp = statistics.median(walls["builtin"]), statistics.median(walls["python"])
    print(f"{builtin:<12} {mb:>10.3f} {mp:>10.3f} {100 * (mp - mb) / mb:>8.1f}% {calls:>6} "
          f"{1e3 * (mp - mb) / max(calls, 1):>7.2f}ms")
print("(same rounds, submissions and balances as the built-in in every pair checked)")

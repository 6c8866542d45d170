"""The overhead of a Python plug-in aggregation rule (issue 34): the smoke preset with 2
Byzantine sign-flippers under the built-in median and under its numpy twin (`rule=`), 5 runs
of each, interleaved; prints the median wall time of each, the difference per run and per call
of the rule (every node's contract calls it at every aggregation, and so do the folds), and
checks that both give the same rounds, submissions and balances.

    pip install ./python
    nice -n 19 python bench/rule_overhead.py [--runs 5] [--duration 600]
"""

import argparse
import statistics
import tempfile
import time

import numpy as np

import swarmfl


class NpMedian(swarmfl.Rule):
    """contract/rules/median.rs in numpy; counts its calls."""

    name = "np-median"
    calls = 0

    def aggregate(self, models, f, current, samples):
        NpMedian.calls += 1
        s = np.sort(models, axis=0)
        n = len(s)
        if n % 2:
            return s[n // 2]
        total = s[n // 2 - 1] + s[n // 2]
        return np.sign(total) * ((np.abs(total) + 1) // 2)


p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
p.add_argument("--runs", type=int, default=5)
p.add_argument("--duration", type=float, default=600.0, help="simulated seconds (smoke: 600)")
args = p.parse_args()
base = {"run.duration_s": args.duration, "byzantine.count": 2, "byzantine.kind": "sign-flip",
        "byzantine.scale": 2.0, "contract.assumed_f": 1}
print(f"smoke preset, {args.duration:g} s, 2 sign-flippers of 15, f = 1, {args.runs} runs each, "
      "interleaved; wall time of swarmfl.run (median)")
print(f"{'rule':<8} {'built-in s':>10} {'python s':>10} {'overhead':>9} {'calls':>6} {'per call':>9}")
walls = {"builtin": [], "python": []}
calls = 0
for i in range(args.runs):
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        a = swarmfl.run(preset="smoke", seed=7, out=f"{d}/b", set={**base, "contract.rule": "median"})
        walls["builtin"].append(time.perf_counter() - t)
        NpMedian.calls = 0
        t = time.perf_counter()
        b = swarmfl.run(preset="smoke", seed=7, out=f"{d}/p", set=base, rule=NpMedian())
        walls["python"].append(time.perf_counter() - t)
        calls = NpMedian.calls
        if i == 0:
            for table in ["rounds", "submissions", "balances"]:
                x, y = getattr(a, table), getattr(b, table)
                assert x.equals(y), f"the plug-in rule's {table} differ from the built-in median's"
mb, mp = statistics.median(walls["builtin"]), statistics.median(walls["python"])
print(f"{'median':<8} {mb:>10.3f} {mp:>10.3f} {100 * (mp - mb) / mb:>8.1f}% {calls:>6} "
      f"{1e3 * (mp - mb) / max(calls, 1):>7.2f}ms")
print("(same rounds, submissions and balances as the built-in median)")

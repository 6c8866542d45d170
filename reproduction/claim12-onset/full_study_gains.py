#!/usr/bin/env python3
"""Smart minus honest token gain per smart count under the paper's ranking, from the full
study's committed e3-smart result files (18 seeds per count; the same configurations and seeds
as this study's `byzantine.count=K` runs, whose final hashes equal them). Per run: the smart
robots' mean gain minus the honest robots' (`tokens.byzantine_mean_gain - honest_mean_gain` of
the result file); per count: mean and 95 % Student-t half-width, as `swarmfl report` and
`swarmfl ranking` compute them. Writes CSV on stdout.

    python3 reproduction/claim12-onset/full_study_gains.py > reproduction/claim12-onset/full-study-gains.csv
"""
import json
import math
import pathlib

T975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
        2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086]

def stat(values):
    n = len(values)
    mean = sum(values) / n
    var = sum((v - mean) ** 2 for v in values) / (n - 1)
    return n, mean, T975[n - 2] * math.sqrt(var) / math.sqrt(n)

root = pathlib.Path(__file__).resolve().parents[1] / "full-study" / "results" / "e3-smart"
print("count,n,smart_gain_mean,smart_gain_ci95,honest_gain_mean,honest_gain_ci95,"
      "gain_difference_mean,gain_difference_ci95")
for count in range(1, 8):
    runs = [json.loads(p.read_text())["tokens"]
            for p in sorted((root / f"byzantine-{count}").glob("seed*.json"))]
    smart = [t["byzantine_mean_gain"] for t in runs]
    honest = [t["honest_mean_gain"] for t in runs]
    diff = [s - h for s, h in zip(smart, honest)]
    cols = [count, len(runs)]
    for values in (smart, honest, diff):
        _, mean, ci = stat(values)
        cols += [f"{mean:.4f}", f"{ci:.4f}"]
    print(",".join(str(c) for c in cols))

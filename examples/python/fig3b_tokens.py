"""Reproduces the paper's Fig. 3b (Exp. 2, faulty robots, security on): the tokens gained on
average by the honest and by the faulty robots against the number of faulty robots (0 to 7),
with 95 % confidence intervals over seeds. REPRODUCTION.md, claim 7, holds the full study's
version (reproduction/reduced-study/e2-faulty-tokens.png).

A short sweep by default (2 seeds of 1000 simulated seconds per point, 16 runs: a few minutes
on 2 cores); the paper's is 20 seeds of 5000 s (--seeds 20 --duration 5000). Resumable: run it
again with the same --out to finish an interrupted sweep.

    pip install ./python matplotlib
    python examples/python/fig3b_tokens.py --out /tmp/fig3b --png fig3b.png
"""

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from scipy_free_t import t_975  # noqa: E402  (the report's Student-t table, below)

import swarmfl  # noqa: E402

p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
p.add_argument("--seeds", type=int, default=2)
p.add_argument("--duration", type=float, default=1000.0, help="simulated seconds per run")
p.add_argument("--jobs", type=int, default=None)
p.add_argument("--out", default="results-fig3b", help="the sweep's results directory")
p.add_argument("--png", default="fig3b.png")
args = p.parse_args()

# One row per run; `x` is the point's number of faulty robots.
df = swarmfl.sweep("e2-faulty", seeds=args.seeds, set={"run.duration_s": args.duration},
                   out=args.out, jobs=args.jobs)
g = df.groupby("x")[["honest_gain", "byzantine_gain"]].agg(["mean", "std", "count"])

fig, ax = plt.subplots(figsize=(6, 4))
for col, label, colour in [("honest_gain", "honest robots", "tab:blue"),
                           ("byzantine_gain", "faulty robots", "tab:red")]:
    s = g[col].dropna()
    half = [t_975(n - 1) * sd / n ** 0.5 if n > 1 else 0.0
            for n, sd in zip(s["count"], s["std"])]
    ax.errorbar(s.index, s["mean"], yerr=half, marker="o", capsize=3, label=label, color=colour)
ax.axhline(0, color="grey", lw=0.8)
ax.set_xlabel("faulty robots")
ax.set_ylabel("tokens gained (mean, 95 % CI)")
ax.set_title(f"e2-faulty: tokens gained ({args.seeds} seeds, {args.duration:.0f} s)")
ax.legend()
fig.tight_layout()
fig.savefig(args.png, dpi=120)
print(g.round(2).to_string())
print(f"wrote {args.png}")

#!/usr/bin/env python3
"""Condenses `e4-heterogeneity`'s report into the tables RESEARCH.md quotes, per rule and
home-range alpha: the clean runs' median final held-out loss as a fraction of genesis (over the
seeds) with its multiple of FedAvg's at the same alpha; at 3 and at 5 Byzantine robots of 15,
the destroyed runs (final loss above the genesis model's) of the 15 attacked runs (3 attacks x
5 seeds) and their median fraction; the destroyed runs per seed at 5 Byzantine (every rule but
FedAvg); and the genesis loss per alpha. A cell whose runs are not all made prints `n/a`.

It reads `e4-heterogeneity-runs.csv`, which `swarmfl report` writes beside `report.md`.

Usage: python3 scripts/e4_heterogeneity_summary.py [reproduction/e4-heterogeneity]
Needs only the standard library.
"""

import csv
import statistics
import sys
from collections import Counter, defaultdict
from pathlib import Path

ALPHAS = ["inf", "10", "1", "0.3", "0.1"]
RULES = [
    "paper",
    "fedavg",
    "median",
    "krum",
    "geomed",
    "centered-clipping",
    "trimmed-mean",
    "nnm+median",
    "gate+median",
]
SEEDS = 5
ATTACKS = 3


def fraction(runs):
    """The median final / genesis of `runs`."""
    return statistics.median(float(r["fraction"]) for r in runs)


def short(x):
    """A fraction in a table cell: three digits, or a power of ten for a destroyed model."""
    return f"{x:.3g}" if x < 1e3 else f"{x:.1e}"


def main():
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "reproduction/e4-heterogeneity")
    table = folder / "e4-heterogeneity-runs.csv"
    if not table.is_file():
        sys.exit(f"{table}: not found; make it with `swarmfl report RESULTS --out {folder}`")
    with table.open(newline="") as f:
        runs = list(csv.DictReader(f))
    cells = defaultdict(list)
    for r in runs:
        cells[(r["rule"], r["alpha"], int(r["count"]))].append(r)
    alphas = [a for a in ALPHAS if any(r["alpha"] == a for r in runs)]
    header = "| rule | " + " | ".join(f"alpha {a}" for a in alphas) + " |"
    rule_line = "|---|" + "---|" * len(alphas)

    print("Clean runs: median final / genesis over the seeds (multiple of FedAvg's)\n")
    print(header)
    print(rule_line)
    for rule in RULES:
        row = []
        for a in alphas:
            own, fedavg = cells.get((rule, a, 0), []), cells.get(("fedavg", a, 0), [])
            if len(own) < SEEDS or len(fedavg) < SEEDS:
                row.append("n/a")
            else:
                row.append(f"{fraction(own):.4f} ({fraction(own) / fraction(fedavg):.1f}x)")
        print(f"| {rule} | " + " | ".join(row) + " |")

    for count in (3, 5):
        print(
            f"\n{count} Byzantine robots of 15: destroyed of {ATTACKS * SEEDS} "
            "(median final / genesis of those runs)\n"
        )
        print(header)
        print(rule_line)
        for rule in RULES:
            row = []
            for a in alphas:
                attacked = cells.get((rule, a, count), [])
                if len(attacked) < ATTACKS * SEEDS:
                    row.append("n/a")
                    continue
                destroyed = sum(r["destroyed"] == "true" for r in attacked)
                row.append(f"{destroyed} ({short(fraction(attacked))})")
            print(f"| {rule} | " + " | ".join(row) + " |")

    print("\nDestroyed runs per seed at 5 Byzantine robots, every rule but FedAvg")
    for a in alphas:
        attacked = [
            r for r in runs if r["alpha"] == a and int(r["count"]) == 5 and r["rule"] != "fedavg"
        ]
        per_seed = Counter(r["seed"] for r in attacked if r["destroyed"] == "true")
        total = sum(per_seed.values())
        if len(attacked) < (len(RULES) - 1) * ATTACKS * SEEDS:
            print(f"alpha {a}: n/a ({len(attacked)} runs made)")
            continue
        print(
            f"alpha {a}: "
            + ", ".join(f"seed {s} {n}" for s, n in sorted(per_seed.items()))
            + f" of {len(attacked)} runs; seeds 1 and 4 hold "
            + (f"{(per_seed['1'] + per_seed['4']) / total:.0%}" if total else "none")
        )

    print("\nThe genesis model's held-out loss per alpha (median, min, max over every run)")
    for a in alphas:
        g = [float(r["genesis_loss"]) for r in runs if r["alpha"] == a]
        print(f"alpha {a}: {statistics.median(g):.3f} ({min(g):.3f} to {max(g):.3f})")


if __name__ == "__main__":
    main()

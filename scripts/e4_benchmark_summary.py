#!/usr/bin/env python3
"""Counts, per rule, Byzantine count and swarm behaviour of the e4-benchmark, the runs whose
model was destroyed: final held-out loss above the genesis model's (the run's own
`heldout_loss_initial`), and, for those, the first round whose held-out loss went above it.

The report's heatmaps give means over seeds, which one destroyed run dominates; this table
gives how often it happens (destroyed runs of the 3 seeds x 4 attacks = 12 per cell) and how
early. RESEARCH.md ("The robustness benchmark at full length") quotes it.

Usage: python3 scripts/e4_benchmark_summary.py [reproduction/e4-benchmark/results]
Needs only the standard library.
"""

import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path


def main() -> None:
    root = Path(sys.argv[1] if len(sys.argv) > 1 else "reproduction/e4-benchmark/results")
    files = sorted(root.glob("e4-benchmark/*/seed*.json"))
    if not files:
        sys.exit(f"{root}: no e4-benchmark result files (seed*.json) below it")
    destroyed = defaultdict(int)  # (rule, behaviour, count) -> runs
    runs = defaultdict(int)
    first_round = defaultdict(list)
    rounds = defaultdict(list)
    behaviours = set()
    heterogeneity = defaultdict(list)  # behaviour -> clean runs' world.data_heterogeneity
    for path in files:
        behaviour, rule, attack, count = path.parent.name.split("--")
        count = int(count)
        run = json.loads(path.read_text())
        if count == 0:
            heterogeneity[behaviour].append(run["world"]["data_heterogeneity"])
            continue
        c = run["contract"]
        key = (rule, behaviour, count)
        behaviours.add(behaviour)
        runs[key] += 1
        genesis = c["heldout_loss_initial"]
        rounds[key].append(c["rounds"])
        if c["final_heldout_loss"] > genesis:
            destroyed[key] += 1
            by_round = c["heldout_loss_by_round"]
            first = next((i + 1 for i, l in enumerate(by_round) if l > genesis), None)
            if first is not None:
                first_round[key].append(first)
    # Columns by the heterogeneity the clean runs measured, as in the report.
    order = sorted(behaviours, key=lambda b: statistics.fmean(heterogeneity[b] or [0.0]))
    rules = sorted({k[0] for k in runs}, key=lambda r: (r != "paper", r != "fedavg", r))
    head = ["rule"] + [f"{b}, {n}" for n in (3, 5) for b in order]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for rule in rules:
        cells = []
        for n in (3, 5):
            for b in order:
                key = (rule, b, n)
                if runs[key] == 0:
                    cells.append("n/a")
                    continue
                cell = f"{destroyed[key]}/{runs[key]}"
                if first_round[key]:
                    cell += f" (round {statistics.median(first_round[key]):g} of {statistics.median(rounds[key]):g})"
                cells.append(cell)
        print(f"| {rule} | " + " | ".join(cells) + " |")
    print()
    print("heterogeneity (mean world.data_heterogeneity of the clean runs): " + ", ".join(
        f"{b} {statistics.fmean(heterogeneity[b]):.4f}" for b in order if heterogeneity[b]))
    print("destroyed runs / runs (3 seeds x 4 attacks); in brackets the median first round whose")
    print("held-out loss exceeded the genesis model's, and the median rounds a run closed.")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Compares, per swarm behaviour, the rules of `e4-gate` (median and krum behind the paper's
outlier threshold, `contract.threshold_gate`) with their `e4-benchmark` namesakes without the
gate and with the paper's rule, on the same points, seeds and settings: the clean runs' final
held-out loss, and at 5 Byzantine robots of 15 the destroyed runs (final held-out loss above
the genesis model's, of 3 seeds x 4 attacks), the worst case over the attacks (mean over the
seeds, as the benchmark's report), the median final held-out loss of the 12 attacked runs and
the share of aggregated models that were Byzantine. RESEARCH.md ("The threshold in front of a
robust rule") quotes it.

Usage: python3 scripts/e4_gate_summary.py [reproduction/e4-gate/results
                                           [reproduction/e4-benchmark/results]]
Needs only the standard library.
"""

import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path

RULES = ["paper", "median", "gate+median", "krum", "gate+krum"]


def load(root: Path, experiment: str, cells: dict) -> int:
    files = sorted(root.glob(f"{experiment}/*/seed*.json"))
    for path in files:
        behaviour, rule, attack, count = path.parent.name.split("--")
        if rule not in RULES or int(count) not in (0, 5):
            continue
        run = json.loads(path.read_text())
        cells[(behaviour, rule, int(count))].append((attack, run))
    return len(files)


def fmt(x: float) -> str:
    return f"{x:.3g}"


def main() -> None:
    gate = Path(sys.argv[1] if len(sys.argv) > 1 else "reproduction/e4-gate/results")
    bench = Path(sys.argv[2] if len(sys.argv) > 2 else "reproduction/e4-benchmark/results")
    cells = defaultdict(list)
    if load(gate, "e4-gate", cells) == 0:
        sys.exit(f"{gate}: no e4-gate result files (seed*.json) below it")
    if load(bench, "e4-benchmark", cells) == 0:
        sys.exit(f"{bench}: no e4-benchmark result files (seed*.json) below it")
    behaviours = ["flocking", "mixed", "avoidance"]
    head = ["rule", "swarm", "clean (mean of 3)", "destroyed at 5", "worst case at 5",
            "median of the 12 at 5", "Byzantine share of aggregated models at 5",
            "outliers refused per run at 5"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for behaviour in behaviours:
        for rule in RULES:
            clean = cells[(behaviour, rule, 0)]
            attacked = cells[(behaviour, rule, 5)]
            if not clean or not attacked:
                print(f"| {rule} | {behaviour} | " + " | ".join(["n/a"] * (len(head) - 2)) + " |")
                continue
            c_loss = statistics.fmean(r["contract"]["final_heldout_loss"] for _, r in clean)
            destroyed = sum(
                r["contract"]["final_heldout_loss"] > r["contract"]["heldout_loss_initial"]
                for _, r in attacked
            )
            by_attack = defaultdict(list)
            for attack, r in attacked:
                by_attack[attack].append(r["contract"]["final_heldout_loss"])
            worst_attack, worst = max(
                ((a, statistics.fmean(v)) for a, v in by_attack.items()), key=lambda t: t[1]
            )
            median = statistics.median(r["contract"]["final_heldout_loss"] for _, r in attacked)
            byz = sum(r["contract"]["aggregated_byzantine"] for _, r in attacked)
            honest = sum(r["contract"]["aggregated_honest"] for _, r in attacked)
            share = byz / (byz + honest) if byz + honest else float("nan")
            outliers = statistics.fmean(
                r["contract"]["submissions"].get("outlier", 0) for _, r in attacked
            )
            print(
                f"| {rule} | {behaviour} | {fmt(c_loss)} | {destroyed}/{len(attacked)} | "
                f"{fmt(worst)} ({worst_attack}) | {fmt(median)} | {share:.3f} | {outliers:.1f} |"
            )
    print()
    print("destroyed: final held-out loss above the run's genesis model's; worst case: the attack")
    print("with the highest mean final held-out loss over the 3 seeds; gate+: e4-gate's runs,")
    print("the rest e4-benchmark's (same preset, points, seeds).")


if __name__ == "__main__":
    main()

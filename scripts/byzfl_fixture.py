#!/usr/bin/env python3
"""Writes core/tests/data/byzfl.json: ByzFL's own aggregates of quantised vectors, which
core/tests/byzfl.rs compares with swarmfl's integer rules (issue #33).

Each case is q models of `len` weights in swarmfl's fixed point (integers, scale 1e9, as the
contract stores them): honest ones around a random center and f outliers far away, plus the
shared model `current` the round was opened on. ByzFL 0.0.11 gets exactly the same values as
float64 (units / 1e9, exact for |units| < 2^53 up to the one division) and runs its numpy code
paths: Average, Median, TrMean(f), GeometricMedian (nu = 1e-9, one unit, as swarmfl's 1-unit
distance floor; T = 5000 steps, run to convergence), Krum(f), MultiKrum(f),
CenteredClipping (its center set to `current`, L = 3 iterations, tau = swarmfl's radius, which
the script computes exactly as swarmfl does), MDA(f), MoNNA(f, idx = 0) and Meamed(f). The
results are stored in units (float). For GeometricMedian the script also records the
Weiszfeld contraction rate it observes on ByzFL's own iterates, which the Rust test's tolerance
uses (its derivation is in the test).

ByzFL imports torch at module level but its numpy paths never call it; this script installs a
stand-in `torch` module (a class `Tensor` that no numpy array is an instance of) so that the
numpy code runs without the 2 GB torch wheel. Nothing else of ByzFL is replaced.

Usage: pip install numpy scipy && pip install --no-deps byzfl==0.0.11
       python3 scripts/byzfl_fixture.py [out.json]
"""
import importlib
import importlib.util
import json
import math
import os
import sys
import types

import numpy as np

SCALE = 1_000_000_000


def load_byzfl():
    """ByzFL's aggregators module, imported without torch and without byzfl/__init__.py
    (which imports the torch-based federated framework)."""
    torch = types.ModuleType("torch")

    class Tensor:  # never an instance: the numpy branches are taken
        pass

    torch.Tensor = Tensor
    torch.linalg = types.ModuleType("torch.linalg")
    sys.modules["torch"] = torch
    sys.modules["torch.linalg"] = torch.linalg
    spec = importlib.util.find_spec("byzfl")
    if spec is None or not spec.submodule_search_locations:
        sys.exit("byzfl is not installed: pip install --no-deps byzfl==0.0.11")
    root = list(spec.submodule_search_locations)[0]
    pkg = types.ModuleType("byzfl")
    pkg.__path__ = [root]
    sys.modules["byzfl"] = pkg
    return importlib.import_module("byzfl.aggregators.aggregators")


def cc_radius(models, current):
    """swarmfl's centered-clipping radius: the lower median of floor(sqrt(|w_k - current|^2))."""
    norms = sorted(
        math.isqrt(sum((a - c) ** 2 for a, c in zip(w, current))) for w in models
    )
    return norms[(len(norms) - 1) // 2]


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(__file__), "..", "core", "tests", "data", "byzfl.json"
    )
    agg = load_byzfl()
    rng = np.random.default_rng(33)
    cases = []
    shapes = [(5, 1, 3), (5, 2, 4), (7, 1, 3), (7, 2, 6), (7, 3, 2), (9, 2, 5),
              (9, 4, 3), (10, 2, 4), (10, 3, 8), (11, 3, 5), (12, 5, 3), (8, 1, 16)]
    for q, f, length in shapes:
        center = rng.normal(0.0, 1.0, length)
        current = center + rng.normal(0.0, 0.05, length)
        honest = center + rng.normal(0.0, 0.05, (q - f, length))
        far = center + rng.normal(0.0, 1.0, (f, length)) * rng.choice([3.0, 30.0, 300.0])
        models_f = np.vstack([far, honest])
        rng.shuffle(models_f, axis=0)
        models = [[int(round(x * SCALE)) for x in w] for w in models_f]
        current_u = [int(round(x * SCALE)) for x in current]
        x = np.array(models, dtype=np.float64) / SCALE
        cur = np.array(current_u, dtype=np.float64) / SCALE
        tau = cc_radius(models, current_u)

        cc = agg.CenteredClipping(L=3, tau=float(tau) / SCALE)
        cc.m = cur.copy()
        # ByzFL's Weiszfeld iterates z_t (T = t steps from 0), for the contraction rate.
        steps = [agg.GeometricMedian(nu=1e-9, T=t)(x) for t in range(0, 80)]
        rates = []
        for t in range(1, len(steps) - 1):
            a = np.linalg.norm(steps[t] - steps[t - 1]) * SCALE
            b = np.linalg.norm(steps[t + 1] - steps[t]) * SCALE
            if a > 1e4 and b > 1e3:  # well above float noise (~1e-5 units)
                rates.append(b / a)
        rho = min(max(rates) if rates else 0.0, 0.99)

        def units(v):
            return [float(e) * SCALE for e in np.asarray(v, dtype=np.float64)]

        cases.append({
            "q": q,
            "f": f,
            "current": current_u,
            "models": models,
            "cc_tau_units": tau,
            "geomed_rate": rho,
            "byzfl": {
                "Average": units(agg.Average()(x)),
                "Median": units(agg.Median()(x)),
                "TrMean": units(agg.TrMean(f)(x)),
                "GeometricMedian": units(agg.GeometricMedian(nu=1e-9, T=5000)(x)),
                "Krum": units(agg.Krum(f)(x)),
                "MultiKrum": units(agg.MultiKrum(f)(x)),
                "CenteredClipping": units(cc(x)),
                "MDA": units(agg.MDA(f)(x)),
                "MoNNA": units(agg.MoNNA(f, 0)(x)),
                "Meamed": units(agg.Meamed(f)(x)),
            },
        })
    doc = {
        "source": "ByzFL 0.0.11 numpy aggregators (scripts/byzfl_fixture.py)",
        "scale": SCALE,
        "cases": cases,
    }
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(out, "w") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")
    print(f"wrote {len(cases)} cases to {out}")


if __name__ == "__main__":
    main()

"""A custom aggregation rule in Python: the coordinate-wise median in numpy, run on chain by
every node's contract (contract.rule = "plugin"), compared with the built-in median.
Integers in, integers out: the models are fixed point (contract.weight_scale).
Usage: python custom_rule.py [OUT_DIR]"""
import sys
import tempfile
from pathlib import Path

import numpy as np

import swarmfl


def np_median(models, f, current, samples):
    """models: (n, d) int64, one accepted model per row; returns the next model, d int64."""
    s = np.sort(models, axis=0)
    n = len(s)
    if n % 2:
        return s[n // 2]
    total = s[n // 2 - 1] + s[n // 2]                  # even n: round half away from zero
    return np.sign(total) * ((np.abs(total) + 1) // 2)


out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="custom-rule-"))
attack = {"run.duration_s": 200.0, "byzantine.count": 2, "byzantine.kind": "sign-flip",
          "byzantine.scale": 2.0, "contract.assumed_f": 1}
mine = swarmfl.run(preset="smoke", seed=7, out=out / "python", set=attack, rule=np_median)
theirs = swarmfl.run(preset="smoke", seed=7, out=out / "builtin",
                     set={**attack, "contract.rule": "median"})
print(mine.rounds[["round", "block", "accepted", "loss"]])
same = all(getattr(mine, t).equals(getattr(theirs, t)) for t in ["rounds", "submissions", "balances"])
print("same records as the built-in median:", same)

"""A custom attack in Python: copy the round's first honest model, nudged away from the shared
model, and claim many samples. Usage: python custom_attack.py [OUT_DIR]"""
import sys

import swarmfl


class PushAway(swarmfl.Attack):
    factor = 3.0  # how far past the honest model, in honest steps

    def act(self, view):
        honest = view.honest_models          # the round's honest submissions on this chain
        if len(honest) == 0:
            return None if not view.last_chance else (view.shared, view.claimed_samples)
        step = honest[0] - view.shared       # one honest robot's update
        return view.shared + self.factor * step, 1000


out = sys.argv[1] if len(sys.argv) > 1 else None
r = swarmfl.run(preset="smoke", seed=7, out=out, attack=PushAway(),
                set={"run.duration_s": 200.0, "byzantine.count": 3})
final = r.balances[r.balances.block == r.balances.block.max()]
print(final.groupby("byzantine").balance_tokens.mean().rename({True: "Byzantine robots", False: "honest robots"}))

"""A custom attack in Python: copy the round's first honest model, pushed past it away from the
shared model, and claim as many samples as the contract takes (its claim bound, read from the
view: a larger claim is refused as malformed), so that a sample-weighted rule weighs it most.
Prints what the contract made of the Byzantine submissions (by verdict, with the reasons of
any refusal) and both sides' tokens. Usage: python custom_attack.py [OUT_DIR]"""
import sys

import swarmfl


class PushAway(swarmfl.Attack):
    factor = 3.0  # how far past the honest model, in honest steps

    def act(self, view):
        honest = view.honest_models          # the round's honest submissions on this chain
        if len(honest) == 0:
            return None if not view.last_chance else (view.shared, view.claim_bound)
        step = honest[0] - view.shared       # one honest robot's update
        return view.shared + self.factor * step, view.claim_bound


def main(out=None):
    r = swarmfl.run(preset="smoke", seed=7, out=out, attack=PushAway(),
                    set={"run.duration_s": 200.0, "byzantine.count": 3})
    byz = r.outcomes[r.outcomes.byzantine]
    counts = byz.outcome.value_counts()
    print(f"Byzantine submissions on the final chain: {len(byz)}, claiming "
          f"{sorted(set(byz.samples))} samples; by verdict: "
          + ", ".join(f"{n} {verdict}" for verdict, n in counts.items()))
    refused = byz[byz.reason != ""]
    for reason, n in refused.reason.value_counts().items():
        print(f"  refused {n} times: {reason}")
    final = r.balances[r.balances.block == r.balances.block.max()]
    print(final.groupby("byzantine").balance_tokens.mean()
          .rename({True: "Byzantine robots", False: "honest robots"}))
    return r


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)

#!/usr/bin/env bash
# The two studies of issue #57, built on `swarmfl blame` and `swarmfl contributions`.
#
#   scripts/blame-studies.sh localisation OUT [tiny]   # who is Byzantine: top-f accuracy
#   scripts/blame-studies.sh rewards OUT [tiny]        # tokens gained vs Shapley contribution
#   scripts/blame-studies.sh summarise OUT             # both tables (python3, stdlib only)
#
# Localisation: 6 attacks that harm the model (fedavg under sign flipping and extreme values,
# median under the line-searched ALIE and IPM, the paper's rule under smart and malicious) x
# f = 1, 2, 3 Byzantine of 15 x 10 seeds = 180 runs of 1000 s (the harm shows within the first
# rounds: rounds close every ~100 s), each blamed on the held-out loss at the end
# (15 counterfactuals, --no-honest). Estimate: a 1000 s paper run is ~7 s CPU, so 16 x 7 s x
# 180 = ~5.6 CPU-hours. Reported: how often the f robots of largest influence are exactly the
# Byzantine set, per attack and f, with a Wilson 95 % interval (FedDebug: 100 % at 1, 90.3 %
# with several faulty clients).
#
# Rewards: faulty, malicious and smart x 1, 2, 3 Byzantine x 3 seeds = 27 runs of 1000 s (a
# sample of e2/e3's cells), each with Shapley values from 10 sampled orders (<= 151 coalition
# runs, each run once; coalitions without most robots train little, ~half a run on average):
# ~27 x 80 x 7 s = ~4.2 CPU-hours. Reported: per kind and count, the mean Spearman correlation
# between each robot's tokens gained (final balance - initial) and its Shapley contribution
# (minus its Shapley value of the held-out loss: positive = it lowered the loss), and the smart
# robots' mean contribution.
#
# Together ~10 CPU-hours; `tiny` runs one seed of one cell per study at 150 s (a check, minutes).
set -euo pipefail
BIN=${SWARMFL_BIN:-./target/release/swarmfl}
study=${1:?localisation, rewards or summarise}
out=${2:?output folder}
tiny=${3:-}
mkdir -p "$out"

run() { # dir seed overrides...
  local dir=$1 seed=$2; shift 2
  local sets=()
  for s in "$@"; do sets+=(--set "$s"); done
  [ -f "$dir/run.swlog" ] || "$BIN" run --preset paper --seed "$seed" "${sets[@]}" --out "$dir" --quiet >/dev/null
}

localisation() {
  local duration=1000 seeds="1 2 3 4 5 6 7 8 9 10" counts="1 2 3"
  local cells=(
    "fedavg-signflip contract.rule=fedavg byzantine.kind=sign-flip"
    "fedavg-extreme contract.rule=fedavg byzantine.kind=faulty byzantine.faulty_range=100"
    "median-optalie contract.rule=median byzantine.kind=optimal-alie"
    "median-optipm contract.rule=median byzantine.kind=optimal-ipm"
    "paper-smart contract.rule=paper byzantine.kind=smart"
    "paper-malicious contract.rule=paper byzantine.kind=malicious"
  )
  if [ -n "$tiny" ]; then duration=150; seeds=1; counts=1; cells=("${cells[0]}"); fi
  for cell in "${cells[@]}"; do
    set -- $cell; local name=$1; shift
    for f in $counts; do for seed in $seeds; do
      local dir="$out/localisation/$name-f$f-seed$seed"
      run "$dir" "$seed" "run.duration_s=$duration" "byzantine.count=$f" "$@"
      [ -f "$dir/blame.json" ] || "$BIN" blame "$dir/run.swlog" --no-honest --json --quiet > "$dir/blame.json"
    done; done
  done
}

rewards() {
  local duration=1000 seeds="1 2 3" counts="1 2 3" kinds="faulty malicious smart" samples=10
  if [ -n "$tiny" ]; then duration=150; seeds=1; counts=1; kinds=smart; samples=2; fi
  for kind in $kinds; do for f in $counts; do for seed in $seeds; do
    local dir="$out/rewards/$kind-f$f-seed$seed"
    run "$dir" "$seed" "run.duration_s=$duration" "byzantine.kind=$kind" "byzantine.count=$f"
    [ -f "$dir/contributions.json" ] || "$BIN" contributions "$dir/run.swlog" --samples "$samples" --seed "$seed" --json --quiet > "$dir/contributions.json"
    [ -f "$dir/export/balances.csv" ] || "$BIN" export "$dir/run.swlog" --out "$dir/export" >/dev/null
  done; done; done
}

summarise() {
  python3 - "$out" <<'PY'
import json, math, pathlib, sys, collections
out = pathlib.Path(sys.argv[1])
def wilson(k, n):
    if n == 0: return (float("nan"),) * 2
    z, p = 1.96, k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return c - h, c + h
cells = collections.defaultdict(list)
for b in sorted(out.glob("localisation/*/blame.json")):
    r = json.loads(b.read_text())
    name = b.parent.name.rsplit("-seed", 1)[0]
    f = int(name.rsplit("-f", 1)[1])
    top = {x["robot"] for x in r["robots"][:f]}
    byz = {x["robot"] for x in r["robots"] if x["byzantine"]}
    cells[name].append((top == byz, r["wall_s"], r["cpu_s"]))
if cells:
    print("| attack, f | runs | top f = Byzantine set | 95 % interval | CPU s per localisation |")
    print("|---|---|---|---|---|")
    for name, xs in cells.items():
        k = sum(x[0] for x in xs); lo, hi = wilson(k, len(xs))
        print(f"| {name} | {len(xs)} | {100*k/len(xs):.0f} % | {100*lo:.0f}-{100*hi:.0f} % | {sum(x[2] for x in xs)/len(xs):.0f} |")
def ranks(v):
    order = sorted(range(len(v)), key=lambda i: v[i]); r = [0.0] * len(v); i = 0
    while i < len(v):
        j = i
        while j + 1 < len(v) and v[order[j + 1]] == v[order[i]]: j += 1
        for k in range(i, j + 1): r[order[k]] = (i + j) / 2
        i = j + 1
    return r
def spearman(a, b):
    ra, rb = ranks(a), ranks(b); n = len(a)
    ma, mb = sum(ra) / n, sum(rb) / n
    cov = sum((x - ma) * (y - mb) for x, y in zip(ra, rb))
    va = math.sqrt(sum((x - ma) ** 2 for x in ra)); vb = math.sqrt(sum((y - mb) ** 2 for y in rb))
    return cov / (va * vb) if va and vb else float("nan")
groups = collections.defaultdict(list)
for c in sorted(out.glob("rewards/*/contributions.json")):
    r = json.loads(c.read_text())
    import csv
    rows = list(csv.DictReader(open(c.parent / "export" / "balances.csv")))
    first, last = {}, {}
    for row in rows:
        first.setdefault(int(row["robot"]), float(row["balance_tokens"]))
        last[int(row["robot"])] = float(row["balance_tokens"])
    tokens = [last[i] - first[i] for i in sorted(last)]
    contrib = [-(x["shapley"] or 0.0) for x in r["robots"]]
    smart = [contrib[x["robot"]] for x in r["robots"] if x["byzantine"]]
    name = c.parent.name.rsplit("-seed", 1)[0]
    groups[name].append((spearman(tokens, contrib), sum(smart) / max(len(smart), 1),
                         max((x["shapley_se"] or 0.0) for x in r["robots"])))
if groups:
    print()
    print("| kind, f | runs | Spearman(tokens, contribution) | Byzantine mean contribution | largest Shapley s.e. |")
    print("|---|---|---|---|---|")
    for name, xs in groups.items():
        n = len(xs)
        print(f"| {name} | {n} | {sum(x[0] for x in xs)/n:.2f} | {sum(x[1] for x in xs)/n:.3g} | {max(x[2] for x in xs):.2g} |")
PY
}

case $study in
  localisation) localisation ;;
  rewards) rewards ;;
  summarise) summarise ;;
  *) echo "unknown study $study: localisation, rewards or summarise" >&2; exit 2 ;;
esac

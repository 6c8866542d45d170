#!/usr/bin/env bash
# The two studies of issue #57, built on `swarmfl blame` and `swarmfl contributions`.
#
#   scripts/blame-studies.sh localisation OUT [tiny]   # who is Byzantine: top-f accuracy
#   scripts/blame-studies.sh rewards OUT [tiny]        # tokens gained vs Shapley contribution
#   scripts/blame-studies.sh summarise OUT             # both tables (python3, stdlib only)
#   scripts/blame-studies.sh collect OUT DEST          # copy the small files (no logs) to DEST
#   scripts/blame-studies.sh recheck DIR               # one committed localisation, made again
#
# Localisation: 6 attacks that harm the model (fedavg under sign flipping and extreme values,
# median under the line-searched ALIE and IPM, the paper's rule under smart and malicious) x
# f = 1, 2, 3 Byzantine of 15 x 10 seeds = 180 runs of 1000 s (the harm shows within the first
# rounds: rounds close every ~100 s), each blamed on the held-out loss at the end
# (15 counterfactuals, --no-honest). Measured: a 1000 s paper run is ~3 CPU-s, a localisation
# ~40 CPU-s and ~30 s of wall on 2 cores, so the study is ~2 CPU-hours (95 min of wall). Reported: how often the f robots of largest influence are exactly the
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
# Estimated together ~10 CPU-hours before the first was run; see the study's README for what
# they took; `tiny` runs one seed of one cell per study at 150 s (a check, minutes).
set -euo pipefail
BIN=${SWARMFL_BIN:-./target/release/swarmfl}
study=${1:?localisation, rewards, summarise, collect or recheck}
out=${2:?output folder}
tiny=${3:-}
mkdir -p "$out"

run() { # dir seed overrides...
  local dir=$1 seed=$2; shift 2
  local sets=()
  for s in "$@"; do sets+=(--set "$s"); done
  [ -f "$dir/summary.json" ] || "$BIN" run --preset paper --seed "$seed" "${sets[@]}" --out "$dir" --quiet >/dev/null
}

# One localisation: the run, then blame on the held-out loss at its end. Files are written aside
# and renamed, so a study stopped mid-way resumes without a half-written file.
localise() { # dir seed f overrides...
  local dir=$1 seed=$2 f=$3; shift 3
  run "$dir" "$seed" "run.duration_s=$duration" "byzantine.count=$f" "$@"
  if [ ! -s "$dir/blame.json" ]; then
    "$BIN" blame "$dir/run.swlog" --no-honest --json --quiet > "$dir/blame.json.part"
    mv "$dir/blame.json.part" "$dir/blame.json"
  fi
}

duration=1000
cells=(
  "fedavg-signflip contract.rule=fedavg byzantine.kind=sign-flip"
  "median-optalie contract.rule=median byzantine.kind=optimal-alie"
  "median-optipm contract.rule=median byzantine.kind=optimal-ipm"
  "paper-smart contract.rule=paper byzantine.kind=smart"
  "paper-malicious contract.rule=paper byzantine.kind=malicious"
  # Last: its counterfactuals train from models blown up by extreme values, ~4x the CPU of the
  # others (~175 CPU-s a localisation).
  "fedavg-extreme contract.rule=fedavg byzantine.kind=faulty byzantine.faulty_range=100"
)
# BLAME_CELLS="name ..." makes only those cells (default: all, in the order above);
# BLAME_SEEDS="3 ..." only those seeds (default: 1-10 for localisation, 1-3 for rewards).
if [ -n "${BLAME_CELLS:-}" ]; then
  chosen=()
  for cell in "${cells[@]}"; do
    for want in $BLAME_CELLS; do [ "${cell%% *}" = "$want" ] && chosen+=("$cell"); done
  done
  [ ${#chosen[@]} -gt 0 ] || { echo "BLAME_CELLS names no cell: $BLAME_CELLS" >&2; exit 2; }
  cells=("${chosen[@]}")
fi

localisation() {
  local seeds="${BLAME_SEEDS:-1 2 3 4 5 6 7 8 9 10}" counts="1 2 3"
  if [ -n "$tiny" ]; then duration=150; seeds=1; counts=1; cells=("${cells[0]}"); fi
  # The clean run of each rule and seed (no Byzantine robot): how much each cell harms the model.
  for rule in fedavg median paper; do for seed in $seeds; do
    run "$out/clean/$rule-seed$seed" "$seed" "run.duration_s=$duration" "contract.rule=$rule"
  done; done
  for cell in "${cells[@]}"; do
    set -- $cell; local name=$1; shift
    for f in $counts; do for seed in $seeds; do
      localise "$out/localisation/$name-f$f-seed$seed" "$seed" "$f" "$@"
    done; done
  done
}

# CI's check of a committed study (OUT: its folder): the first cell's seed-1, f = 1 localisation
# and the clean run it is measured against, made again by this build (~45 CPU-s) and compared
# with the committed files, the costs apart. Exits 1 naming the first difference.
recheck() {
  local tmp name; tmp=$(mktemp -d); set -- ${cells[0]}; name=$1; shift
  run "$tmp/clean/fedavg-seed1" 1 "run.duration_s=$duration" "contract.rule=fedavg"
  localise "$tmp/localisation/$name-f1-seed1" 1 1 "$@"
  local status=0
  python3 - "$out" "$tmp" "clean/fedavg-seed1" "localisation/$name-f1-seed1" <<'PY' || status=1
import json, pathlib, sys
committed, fresh = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
costs = {"wall_s", "cpu_s", "log", "timing"}  # wall clock and the run's own path
def strip(v):
    if isinstance(v, dict): return {k: strip(x) for k, x in v.items() if k not in costs}
    if isinstance(v, list): return [strip(x) for x in v]
    return v
def first_difference(a, b, path):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b: return f"{path}.{k}: only in {'the committed file' if k in a else 'the new run'}"
            d = first_difference(a[k], b[k], f"{path}.{k}")
            if d: return d
        return None
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_difference(x, y, f"{path}[{i}]")
            if d: return d
        return None
    return None if a == b else f"{path}: committed {a!r}, this build {b!r}"
failed = False
for run in sys.argv[3:]:
    for name in ("summary.json", "blame.json") if run.startswith("localisation") else ("summary.json",):
        c = committed / run / name
        if not c.exists():
            print(f"{c}: not committed (run `collect` after the study)"); failed = True; continue
        d = first_difference(strip(json.loads(c.read_text())), strip(json.loads((fresh / run / name).read_text())), "")
        print(f"{c}: {'differs at ' + d if d else 'same'}")
        failed |= bool(d)
sys.exit(1 if failed else 0)
PY
  rm -rf "$tmp"
  return $status
}

rewards() {
  local seeds="${BLAME_SEEDS:-1 2 3}" counts="1 2 3" kinds="faulty malicious smart" samples=10
  if [ -n "$tiny" ]; then duration=150; seeds=1; counts=1; kinds=smart; samples=2; fi
  # Seed by seed, so a study stopped early holds every cell at the seeds it finished.
  for seed in $seeds; do for kind in $kinds; do for f in $counts; do
    local dir="$out/rewards/$kind-f$f-seed$seed"
    run "$dir" "$seed" "run.duration_s=$duration" "byzantine.kind=$kind" "byzantine.count=$f"
    if [ ! -s "$dir/contributions.json" ]; then
      "$BIN" contributions "$dir/run.swlog" --samples "$samples" --seed "$seed" --json --quiet \
        > "$dir/contributions.json.part"
      mv "$dir/contributions.json.part" "$dir/contributions.json"
    fi
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
    return max(0.0, c - h), min(1.0, c + h)
def median(v):
    v = sorted(v); n = len(v)
    return (v[(n - 1) // 2] + v[n // 2]) / 2 if n else float("nan")
def share(xs):
    k, n = sum(xs), len(xs)
    if n == 0: return "-"
    lo, hi = wilson(k, n)
    return f"{k}/{n} = {100*k/n:.0f} % ({100*lo:.0f}-{100*hi:.0f} %)"
cells = collections.defaultdict(list)
for b in sorted(out.glob("localisation/*/blame.json")):
    if b.stat().st_size == 0: continue  # a blame still running (a study made before the rename)
    r = json.loads(b.read_text())
    name, seed = b.parent.name.rsplit("-seed", 1)
    f = int(name.rsplit("-f", 1)[1])
    top = {x["robot"] for x in r["robots"][:f]}
    byz = {x["robot"] for x in r["robots"] if x["byzantine"]}
    clean = out / "clean" / f"{name.split('-')[0]}-seed{seed}" / "summary.json"
    # Harm: the run's held-out loss at the end over the clean run's of the same rule and seed.
    harm = (r["outcome"] / json.loads(clean.read_text())["contract"]["final_heldout_loss"]
            if clean.exists() else float("nan"))
    # Where the Byzantine robots stand in the ranking: 1 is the most influential of the 15.
    rank = sum(i + 1 for i, x in enumerate(r["robots"]) if x["byzantine"]) / max(len(byz), 1)
    cells[name].append((top == byz, harm, r["cpu_s"], r["wall_s"], rank))
if cells:
    print("Localisation: the f robots of largest influence on the held-out loss at the end, against")
    print("the Byzantine set. Harm: held-out loss at the end over the clean run's (same rule and seed);")
    print("a run is harmed when it is at least 1.1. Intervals: Wilson 95 %.")
    print()
    print("| attack, f | runs | harm (median) | harmed runs | top f = Byzantine, all runs | top f = Byzantine, harmed runs | Byzantine mean rank (1-15) | CPU s / wall s per localisation |")
    print("|---|---|---|---|---|---|---|---|")
    for name, xs in cells.items():
        harmed = [x for x in xs if x[1] >= 1.1]
        print(f"| {name} | {len(xs)} | {median([x[1] for x in xs]):.2f} | {len(harmed)} "
              f"| {share([x[0] for x in xs])} | {share([x[0] for x in harmed])} "
              f"| {sum(x[4] for x in xs) / len(xs):.1f} "
              f"| {median([x[2] for x in xs]):.0f} / {median([x[3] for x in xs]):.0f} |")
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
import csv
for c in sorted(out.glob("rewards/*/contributions.json")):
    r = json.loads(c.read_text())
    rows = list(csv.DictReader(open(c.parent / "export" / "balances.csv")))
    first, last = {}, {}
    for row in rows:
        first.setdefault(int(row["robot"]), float(row["balance_tokens"]))
        last[int(row["robot"])] = float(row["balance_tokens"])
    tokens = [last[i] - first[i] for i in sorted(last)]
    # Contribution: minus the robot's value of the held-out loss (positive: it lowered the loss).
    shapley = [-(x["shapley"] or 0.0) for x in r["robots"]]
    loo = [-x["leave_one_out"] for x in r["robots"]]
    byz = [x["robot"] for x in r["robots"] if x["byzantine"]]
    honest = [i for i in range(len(tokens)) if i not in byz]
    mean = lambda v, ids: sum(v[i] for i in ids) / len(ids) if ids else float("nan")
    name = c.parent.name.rsplit("-seed", 1)[0]
    among = spearman([tokens[i] for i in honest], [shapley[i] for i in honest])
    groups[name].append((spearman(tokens, shapley), spearman(tokens, loo), among,
                         mean(tokens, byz), mean(tokens, honest), mean(shapley, byz),
                         mean(shapley, honest), max((x["shapley_se"] or 0.0) for x in r["robots"])))
def t95(v):
    """Mean and 95 % t half-width (blank below 2 values)."""
    n = len(v); m = sum(v) / n
    if n < 2: return f"{m:.2f}"
    t = {1: 12.71, 2: 4.30, 3: 3.18, 4: 2.78, 5: 2.57, 6: 2.45, 7: 2.36, 8: 2.31, 9: 2.26,
         10: 2.23, 11: 2.20, 12: 2.18, 13: 2.16, 14: 2.14, 15: 2.13, 16: 2.12, 17: 2.11,
         18: 2.10, 19: 2.09, 20: 2.09, 21: 2.08, 22: 2.07, 23: 2.07, 24: 2.06, 25: 2.06,
         26: 2.06}.get(n - 1, 2.05 if n <= 31 else 2.0)
    sd = math.sqrt(sum((x - m) ** 2 for x in v) / (n - 1))
    return f"{m:.2f} ± {t * sd / math.sqrt(n):.2f}"
if groups:
    print()
    print("Rewards against contribution: per run, Spearman's rank correlation over the 15 robots between")
    print("tokens gained (final balance - initial) and contribution (minus the robot's Shapley value,")
    print("or leave-one-out, of the held-out loss at the end: positive = it lowered the loss); means")
    print("over the runs with 95 % t half-widths. Shapley from 10 sampled orders a run.")
    print()
    def table(heads, rows, cells):
        """A markdown table: one row per (name, runs) of `rows`, its cells from `cells`."""
        print("| " + " | ".join(heads) + " |")
        print("|" + "---|" * len(heads))
        for name, xs in rows.items():
            col = lambda k: [x[k] for x in xs]
            mean = lambda k: sum(col(k)) / len(xs)
            print(f"| {name} | {len(xs)} | " + " | ".join(cells(col, mean)) + " |")
    table(["kind, f", "runs", "Spearman(tokens, Shapley)", "Spearman(tokens, leave-one-out)",
           "Spearman(tokens, Shapley), honest robots only", "tokens gained: Byzantine / honest",
           "contribution: Byzantine / honest", "largest Shapley s.e."], groups,
          lambda col, mean: [t95(col(0)), t95(col(1)), t95(col(2)),
                             f"{mean(3):+.2f} / {mean(4):+.2f}", f"{mean(5):+.3f} / {mean(6):+.3f}",
                             f"{max(col(7)):.2f}"])
    # Pooled over the Byzantine counts (per kind), then over every run: the figures the study's
    # prose quotes, each a mean over runs with its 95 % t half-width.
    kinds = collections.defaultdict(list)
    for name, xs in groups.items():
        kinds[name.rsplit("-f", 1)[0]].extend(xs)
    kinds["all"] = [x for xs in groups.values() for x in xs]
    print()
    print("Pooled over the Byzantine counts (1-3), then over every run:")
    print()
    table(["kind", "runs", "Spearman(tokens, Shapley)",
           "Spearman(tokens, Shapley), honest robots only", "tokens gained: Byzantine / honest",
           "contribution: Byzantine", "contribution: honest"], kinds,
          lambda col, mean: [t95(col(0)), t95(col(2)), f"{mean(3):+.2f} / {mean(4):+.2f}",
                             t95(col(5)), t95(col(6))])
PY
}

# The small files of both studies, without the logs (a 1000 s log is ~3 MB), for committing.
collect() {
  local dest=${3:?collect OUT DEST}
  dest=$(mkdir -p "$dest" && cd "$dest" && pwd)  # absolute: the copy runs from OUT
  (cd "$out" && find . \( -name summary.json -o -name blame.json -o -name contributions.json \
    -o -path '*/export/balances.csv' \) -print0 | while IFS= read -r -d '' f; do
      mkdir -p "$dest/$(dirname "$f")"; cp "$f" "$dest/$f"
    done)
}

case $study in
  localisation) localisation ;;
  rewards) rewards ;;
  summarise) summarise ;;
  collect) collect "$@" ;;
  recheck) recheck ;;
  *) echo "unknown study $study: localisation, rewards, summarise, collect or recheck" >&2; exit 2 ;;
esac

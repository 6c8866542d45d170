#!/usr/bin/env bash
# Every aggregation rule against every attack: a `smoke` run (600 s, or DURATION_S) with
# COUNT Byzantine robots (default 3) for each (rule, attack) pair, then `swarmfl replay` on its
# log, which must report its hash chain and checkpoints consistent. Prints one line per pair with the final held-out loss and
# the wall time of run and replay. PAIRS=diagonal runs only 16 pairs (pair i is rule i mod 14
# with attack i mod 16, so every rule and every attack appears) instead of all 224. Then every
# pre-aggregator (contract.preaggregators) runs once in front of a rule against an adaptive
# attack (PREAGG=0 skips them), and the threshold gate (contract.threshold_gate) in front of
# two rules, replayed the same way.
set -euo pipefail
cd "$(dirname "$0")/.."
DURATION_S=${DURATION_S:-600}
COUNT=${COUNT:-3}
SEED=${SEED:-1}
PAIRS=${PAIRS:-all}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

cargo build --release --locked -p replay-cli
BIN=target/release/swarmfl
RULES=(fedavg paper krum multi-krum median trimmed-mean geomed centered-clipping bulyan mda meamed monna signguard dnc)
ATTACKS=(faulty malicious smart sign-flip gaussian alie ipm min-max mimic inflate-samples poison-data collude
         optimal-alie optimal-ipm extreme-value mirror-targets)
# (pre-aggregator chain, rule, attack): each stage once, and one chain of two.
PREAGGS=('["nnm"] krum optimal-alie' '["bucketing"] median optimal-ipm' '["clipping"] paper extreme-value'
         '["arc"] trimmed-mean mirror-targets' '["nnm","arc"] geomed optimal-ipm')
# (rule, attack) behind the paper's threshold (contract.threshold_gate = true).
GATES=('median optimal-ipm' 'krum optimal-alie')
PREAGG=${PREAGG:-1}

one() {
    local rule=$1 attack=$2 chain=${3:-[]} gate=${4:-false}
    local dir="$OUT/$1-$2-$(printf %s "$chain" | tr -dc a-z)-$gate"
    local t0 t1 t2
    t0=$(date +%s.%N)
    $BIN run --preset smoke --seed "$SEED" --out "$dir" --quiet \
        --set run.duration_s="$DURATION_S" --set learn.learning_rate=0.01 \
        --set contract.rule="$rule" --set contract.assumed_f=1 \
        --set byzantine.kind="$attack" --set byzantine.count="$COUNT" \
        --set "contract.preaggregators=$chain" --set contract.threshold_gate="$gate"
    t1=$(date +%s.%N)
    $BIN replay "$dir/run.swlog" > "$dir/replay.txt"
    t2=$(date +%s.%N)
    grep -q "hash chain and checkpoints consistent" "$dir/replay.txt" || { echo "$rule $attack: replay not consistent"; cat "$dir/replay.txt"; exit 1; }
    python3 - "$dir/summary.json" "$rule" "$attack" "$t0" "$t1" "$t2" "$chain" "$gate" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
h = (s.get("contract") or {}).get("heldout_loss_by_round") or []
loss = f"{h[-1]:.5f}" if h else "n/a"
t0, t1, t2 = map(float, sys.argv[4:7])
chain = "" if sys.argv[7] == "[]" else " after " + sys.argv[7]
chain += " gated" if sys.argv[8] == "true" else ""
print(f"{sys.argv[2] + chain:18} {sys.argv[3]:16} rounds {len(h):3}  held-out {loss:>9}  run {t1-t0:5.1f} s  replay {t2-t1:4.1f} s  consistent")
PY
    rm -f "$dir/run.swlog"
}

if [ "$PAIRS" = diagonal ]; then
    n=$(( ${#RULES[@]} > ${#ATTACKS[@]} ? ${#RULES[@]} : ${#ATTACKS[@]} ))
    for ((i = 0; i < n; i++)); do one "${RULES[$((i % ${#RULES[@]}))]}" "${ATTACKS[$((i % ${#ATTACKS[@]}))]}"; done
else
    for rule in "${RULES[@]}"; do for attack in "${ATTACKS[@]}"; do one "$rule" "$attack"; done; done
fi
if [ "$PREAGG" = 1 ]; then
    for entry in "${PREAGGS[@]}"; do
        read -r chain rule attack <<< "$entry"
        one "$rule" "$attack" "$chain"
    done
    for entry in "${GATES[@]}"; do
        read -r rule attack <<< "$entry"
        one "$rule" "$attack" "[]" true
    done
fi

#!/usr/bin/env bash
# End-to-end determinism: the same seed and config give byte-identical logs and the same final
# hash on 1 thread and on many, in a debug and in a release build; `replay` (both modes) says
# bit-exact. Set TARGET_CPU_CHECK=1 to also compare a `-C target-cpu=x86-64-v3` build.
set -euo pipefail
cd "$(dirname "$0")/.."
PRESET=${PRESET:-smoke}
SEED=${SEED:-7}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

cargo build --release --locked -p replay-cli
# The debug build's code without its debug info (CARGO_PROFILE_DEV_DEBUG, for this build only):
# debug info changes no instruction, and writing it for every dependency lengthens the build
# (measured in docs/PERFORMANCE.md, "Build time"); the dev profile in Cargo.toml keeps it for a
# developer's debugger.
CARGO_PROFILE_DEV_DEBUG=false cargo build --locked -p replay-cli
REL=target/release/swarmfl
DBG=target/debug/swarmfl

hash_of() { python3 -c "import json,sys;print(json.load(open(sys.argv[1]))['final_hash'])" "$1/summary.json"; }

RAYON_NUM_THREADS=1 $REL run --preset "$PRESET" --seed "$SEED" --out "$OUT/a" --quiet
$REL run --preset "$PRESET" --seed "$SEED" --out "$OUT/b" --quiet
cmp "$OUT/a/run.swlog" "$OUT/b/run.swlog"
echo "release, 1 thread vs default threads: byte-identical logs, final hash $(hash_of "$OUT/a")"

# Other builds: the same records and final hash (`diff` compares records; the header's build
# provenance, e.g. the git commit, may differ between two builds).
$DBG run --preset "$PRESET" --seed "$SEED" --out "$OUT/c" --quiet
$REL diff "$OUT/a/run.swlog" "$OUT/c/run.swlog"
echo "debug build: identical records and final hash"

if [ "${TARGET_CPU_CHECK:-0}" = 1 ]; then
  RUSTFLAGS="-C target-cpu=x86-64-v3" cargo build --release --locked -p replay-cli --target-dir target/v3
  target/v3/release/swarmfl run --preset "$PRESET" --seed "$SEED" --out "$OUT/d" --quiet
  $REL diff "$OUT/a/run.swlog" "$OUT/d/run.swlog"
  echo "x86-64-v3 build: identical records and final hash"
fi

$REL replay "$OUT/a/run.swlog"
$REL replay --resimulate "$OUT/a/run.swlog"

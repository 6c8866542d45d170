#!/usr/bin/env bash
# Re-makes committed studies under reproduction/ with the build at the tip, so that every
# result file comes from it (`swarmfl recheck`, run by CI, checks that they do).
#
#   scripts/remake-studies.sh full-study e5-smart-defence     # the ones named
#   scripts/remake-studies.sh all                              # every study below
#
# Each study's results/ is emptied first (git keeps the old ones), its sweeps run with
# `--jobs ${JOBS:-2}`, then `swarmfl report` writes its report beside results/. `sweep` resumes:
# if this script is interrupted, run it again with RESUME=1 and it keeps the finished files.
# The wall time of every sweep is printed and appended to reproduction/<study>/walltime.txt
# (one line per sitting of a sweep that ran tasks: experiment, tasks run, seconds), for the study's README.
set -euo pipefail
cd "$(dirname "$0")/.."

bin=${SWARMFL:-target/release/swarmfl}
jobs=${JOBS:-2}
if [ ! -x "$bin" ]; then
  cargo build --release --locked -p replay-cli
fi

# study name -> the sweeps that make it ("experiment [sweep args...]", one per line).
sweeps_of() {
  case "$1" in
    full-study)
      printf '%s\n' e1-expiration e1-faulty e2-faulty e2-malicious e3-smart ;;
    reduced-study)
      printf '%s\n' "e1-expiration --runs 5" "e1-faulty --runs 5" "e2-faulty --runs 5" \
        "e2-malicious --runs 5" "e3-smart --runs 5" ;;
    e0-baselines)
      printf '%s\n' "e0-baselines --runs 3" ;;
    e5-smart-defence)
      printf '%s\n' "e5-smart-defence --runs 3" ;;
    e4-robustness-300s)
      printf '%s\n' "e4-robustness --runs 3 --set run.duration_s=300" ;;
    authors-study)
      # Issue 36: e2-malicious and e3-smart at the paper's run counts under the authors'
      # contract (preset `authors`).
      printf '%s\n' e2-malicious-authors e3-smart-authors ;;
    authors-study-comment)
      # Issue 36: the same under the reward weights of the authors' comment, at 5 runs.
      printf '%s\n' "e2-malicious-authors --runs 5 --set contract.reward_weights=[5,4,3,2,1,-1,-2]" \
        "e3-smart-authors --runs 5 --set contract.reward_weights=[5,4,3,2,1,-1,-2]" ;;
    e4-benchmark)
      # 1296 runs of 5000 s (16 rules x 9 points x 3 behaviours x 3 seeds): hours; resumable.
      printf '%s\n' e4-benchmark ;;
    e4-gate)
      # 90 runs of 5000 s: median and krum behind the paper's threshold at 0 and 5 Byzantine.
      printf '%s\n' e4-gate ;;
    e4-heterogeneity-measure)
      # Issue 55: 30 world-only runs of 3600 s (about 4 CPU-min; 60-robot runs ~10 s each).
      printf '%s\n' e4-heterogeneity-measure ;;
    e6-scale)
      # 15, 60 and 240 robots (3 seeds) first: a 1000-robot buffered run takes about 10 min
      # on a quiet 2-core machine, gossip at 1000 robots far longer.
      printf '%s\n' e6-scale e6-scale-1000 ;;
    *)
      echo "remake-studies: no recipe for study '$1' (known: full-study reduced-study e0-baselines e4-robustness-300s e4-benchmark e4-gate e4-heterogeneity-measure e5-smart-defence e6-scale authors-study authors-study-comment)" >&2
      return 1 ;;
  esac
}

studies=("$@")
if [ "${#studies[@]}" -eq 0 ]; then
  echo "usage: scripts/remake-studies.sh STUDY... | all" >&2
  exit 2
fi
if [ "${studies[0]}" = all ]; then
  studies=(full-study reduced-study e0-baselines e4-robustness-300s e5-smart-defence e6-scale)
fi

for study in "${studies[@]}"; do
  dir=reproduction/$study
  recipe=$(sweeps_of "$study")
  if [ "${RESUME:-0}" != 1 ]; then
    rm -rf "$dir/results"
    : > "$dir/walltime.txt"
  fi
  mkdir -p "$dir/results"
  while read -r line; do
    read -r experiment args <<< "$line"
    # (a fresh study has no directory for the experiment yet: find fails, which is 0 files)
    before=$({ find "$dir/results/$experiment" -name 'seed*.json' 2>/dev/null || true; } | wc -l)
    start=$(date +%s)
    # shellcheck disable=SC2086
    "$bin" sweep "$experiment" $args --jobs "$jobs" --out "$dir/results"
    end=$(date +%s)
    tasks=$(find "$dir/results/$experiment" -name 'seed*.json' | wc -l)
    # A resumed sweep that had nothing left to run adds no line (its time is already there);
    # one that ran some tasks records how many it ran, so walltime.txt stays a sum of sittings.
    if [ "$tasks" -gt "$before" ]; then
      echo "$experiment $((tasks - before)) $((end - start))" | tee -a "$dir/walltime.txt"
    fi
  done <<< "$recipe"
  "$bin" report "$dir/results" --out "$dir"
  awk '{ s += $3 } END { printf "%s: %d s of sweeps in all\n", FILENAME, s }' "$dir/walltime.txt"
done

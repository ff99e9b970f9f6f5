#!/usr/bin/env bash
# Memory and time of match_epochs' pair jobs on full-size scans (issue 48), from one plan:
#   make_scene SCENE --preset decades --seed 0 --scan-px 12000 (docs/synthetic-scenes.md) once, then
#   match_epochs plan SCENE/e1 SCENE/e2 --out WORK/plan --no-pictures, and for each configuration a
#   copy of the plan whose jobs run with run-pair under /usr/bin/time: wall seconds, seconds per pair,
#   peak resident memory, images read and served by the cache. Configurations: THREADS:BUDGET:JOBS
#   (JOBS a run-pair --range, or "all"); the default set shows memory against threads and against the
#   number of pairs (and so of images) a process goes through, with and without the image cache.
# Usage: bench/archive_scale.sh MATCH_EPOCHS SCENE WORK [THREADS:BUDGET:JOBS ...]
# Prints a Markdown table on stdout (docs/benchmarks.md, "Archive scale"); the load before each run.
set -euo pipefail
match=$1 scene=$2 work=$3
shift 3
configs=("$@")
[ ${#configs[@]} -gt 0 ] || configs=(1:0:0-0 1:0:0-3 1:0:all 2:0:0-7 2:0:all 2:1G:all)
mkdir -p "$work"
work=$(cd "$work" && pwd)
if [ ! -f "$work/plan/plan.json" ]; then
  rm -rf "$work/plan"
  "$match" plan "$scene/e1" "$scene/e2" --out "$work/plan" --no-pictures --quiet >"$work/plan.log" 2>&1
fi
jobs=$(sed -n 's/^plan: \([0-9]*\) pair jobs.*/\1/p' "$work/plan.log")
echo "| threads | --memory-budget | pairs | wall s | s / pair | peak memory | images read | from the cache | load before |"
echo "|---|---|---|---|---|---|---|---|---|"
for c in "${configs[@]}"; do
  IFS=: read -r threads budget range <<<"$c"
  [ "$range" = all ] && range="0-$((jobs - 1))"
  run="$work/run_${threads}_${budget}_${range}"
  rm -rf "$run" && mkdir -p "$run/jobs" && cp "$work/plan/plan.json" "$work/plan/jobs.tsv" "$run/"
  load=$(cut -d' ' -f1-3 /proc/loadavg)
  /usr/bin/time -f "%e %M" -o "$run/time.txt" "$match" run-pair --plan "$run/plan.json" --range "$range" \
    --threads "$threads" --memory-budget "$budget" --quiet >"$run/log.txt" 2>&1
  read -r wall kb <"$run/time.txt"
  n=$(( ${range#*-} - ${range%-*} + 1 ))
  reads=$(sed -n 's/.*images read \([0-9]*\) times, \([0-9]*\) from the cache.*/\1 \2/p' "$run/log.txt")
  awk -v t="$threads" -v b="$budget" -v n="$n" -v w="$wall" -v kb="$kb" -v r="$reads" -v l="$load" 'BEGIN {
    split(r, x, " "); printf "| %s | %s | %d | %.0f | %.1f | %.2f GB | %s | %s | %s |\n", t, b, n, w, w / n, kb * 1024 / 1e9, x[1], x[2], l }'
done

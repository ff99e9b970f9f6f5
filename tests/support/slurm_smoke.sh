#!/usr/bin/env bash
# shellcheck disable=SC2016  # the jobs' scripts are single-quoted: they expand on the node
# The single-node Slurm cluster of scripts/slurm_cluster.sh, end to end, in a temporary folder:
#   1. start (MaxArraySize 8);
#   2. an array of 4 tasks, each writing task_<id>.txt, and a job after it (afterok) that checks the
#      four files and writes merged.txt: every job COMPLETED, merged.txt there;
#   3. an array whose task 2 fails and a job after it (afterok): 'wait' returns 1 (no hang), the
#      failed task is FAILED, the dependent job CANCELLED and never run;
#   4. an array of 9 tasks is refused (over MaxArraySize);
#   5. stop: no daemon of the cluster is left.
# Prints "skipped: <reason>" and exits 77 when the cluster cannot start (Slurm not installed, not
# root, daemons that do not come up); exits 1 on a failure, 0 when all holds.
# Usage: tests/support/slurm_smoke.sh [PARENT_DIR]   (the temporary folder is made in PARENT_DIR,
# default $TMPDIR or /tmp; the munge socket's path must stay under 108 characters)
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cluster="$root/scripts/slurm_cluster.sh"
parent=${1:-${TMPDIR:-/tmp}}

for b in sbatch squeue scontrol sinfo; do
  command -v "$b" >/dev/null 2>&1 || { echo "skipped: $b is not installed (scripts/slurm_cluster.sh install)"; exit 77; }
done
dir=$(mktemp -d "$parent/slurm_smoke.XXXXXX") || { echo "skipped: cannot make a folder in $parent"; exit 77; }
cleanup() {
  "$cluster" stop "$dir" >/dev/null 2>&1
  rm -rf "$dir"
}
trap cleanup EXIT

fail() { echo "FAILED: $*"; for f in "$dir"/log/slurmctld.log "$dir"/log/slurmd.log; do [ -f "$f" ] && tail -n 5 "$f"; done; exit 1; }
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.2f", b - a }'; }

t=$(now)
# Twice more when another cluster took the ports between the check and the bind.
for attempt in 1 2 3; do
  out=$(SLURM_CLUSTER_MAX_ARRAY_SIZE=8 "$cluster" start "$dir" 2>&1) && break
  if [ "$attempt" = 3 ] || ! grep -qiE "in use" <<<"$out"; then
    echo "skipped: ${out#slurm_cluster: cannot start: }"
    exit 77
  fi
done
echo "start: $(since "$t") s"
# shellcheck disable=SC1091
source "$dir/env"
[ "${SLURM_CONF:-}" = "$dir/slurm.conf" ] || fail "start wrote no usable $dir/env"

# --- 2. array, then a merge after it ---
mkdir -p "$dir/ok"
t=$(now)
array=$(sbatch --parsable --array=0-3 -J smoke_array -D "$dir/ok" -o task_%a.log \
        --wrap 'echo "$SLURM_ARRAY_TASK_ID" > "task_$SLURM_ARRAY_TASK_ID.txt"') || fail "sbatch of the array"
merge=$(sbatch --parsable --dependency="afterok:$array" -J smoke_merge -D "$dir/ok" -o merge.log \
        --wrap 'for i in 0 1 2 3; do [ "$(cat "task_$i.txt")" = "$i" ] || exit 1; done; echo merged > merged.txt') ||
  fail "sbatch of the merge"
report=$("$cluster" wait --timeout 60 "$array" "$merge") || fail "wait on the good round trip returned $?: $report"
echo "array of 4 + merge: $(since "$t") s"
[ "$(grep -c " COMPLETED 0:0 " <<<"$report")" = 5 ] || fail "not 4 + 1 jobs COMPLETED: $report"
[ "$(cat "$dir/ok/merged.txt" 2>/dev/null)" = merged ] || fail "the merge did not run"

# --- 3. a failing task: the job after it never runs, and wait says so ---
mkdir -p "$dir/bad"
t=$(now)
array=$(sbatch --parsable --array=0-3 -J smoke_bad -D "$dir/bad" -o task_%a.log \
        --wrap '[ "$SLURM_ARRAY_TASK_ID" != 2 ]') || fail "sbatch of the failing array"
merge=$(sbatch --parsable --dependency="afterok:$array" -J smoke_never -D "$dir/bad" -o merge.log \
        --wrap 'echo ran > ran.txt') || fail "sbatch of the dependent job"
report=$("$cluster" wait --timeout 60 "$array" "$merge" 2>/dev/null)
rc=$?
echo "failing array + dependent: $(since "$t") s"
[ "$rc" = 1 ] || fail "wait on a failed array returned $rc, not 1: $report"
grep -q "^${array}_2 FAILED " <<<"$report" || fail "task 2 is not reported FAILED: $report"
[ "$(grep -c " COMPLETED 0:0 " <<<"$report")" = 3 ] || fail "tasks 0, 1, 3 are not COMPLETED: $report"
grep -qE "^$merge (CANCELLED|PENDING) .*DependencyNeverSatisfied" <<<"$report" ||
  fail "the dependent job is not reported as never run: $report"
[ ! -e "$dir/bad/ran.txt" ] || fail "the dependent job ran"

# --- 4. MaxArraySize ---
if sbatch --parsable --array=0-8 -D "$dir/bad" -o /dev/null --wrap true >/dev/null 2>&1; then
  fail "an array of 9 tasks was accepted with MaxArraySize=8"
fi

# --- 5. stop ---
pids="$(cat "$dir/slurmctld.pid" "$dir/slurmd.pid" "$dir/munge/munged.pid" 2>/dev/null | tr '\n' ' ')"
t=$(now)
"$cluster" stop "$dir" || fail "stop returned $?"
echo "stop: $(since "$t") s"
for p in $pids; do
  if [ -r "/proc/$p/stat" ] && ! grep -q ') Z ' "/proc/$p/stat" 2>/dev/null; then fail "process $p still runs after stop"; fi
done
echo "slurm smoke: passed"

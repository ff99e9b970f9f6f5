#!/usr/bin/env bash
# match_epochs on a Slurm cluster (issue 48): a single-node cluster (scripts/slurm_cluster.sh) in a
# temporary folder, the small make_scene scene (480 x 360 px, 1 x 2 images, seed 1, with --adjust)
# planned with --emit slurm (arrays of at most 2 tasks, so that the jobs span several arrays),
# submitted with the plan's submit.sh (the arrays, then the merge after all of them), waited for;
# then the outputs byte for byte against the one-process run (tests/support/same_results.cmake).
# Prints "skipped: <reason>" and exits 77 when the cluster cannot start.
# Usage: match_epochs_slurm.sh MAKE_SCENE MATCH_EPOCHS WORK
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cluster="$root/scripts/slurm_cluster.sh"
make_scene=$1 match_epochs=$2 work=$3

for b in sbatch squeue scontrol sinfo; do
  command -v "$b" >/dev/null 2>&1 || { echo "skipped: $b is not installed (scripts/slurm_cluster.sh install)"; exit 77; }
done
rm -rf "$work" && mkdir -p "$work" || { echo "FAILED: cannot make $work"; exit 1; }
# The cluster's own folder is short: munge's socket path must stay under 108 characters.
dir=$(mktemp -d "${TMPDIR:-/tmp}/slurm_me.XXXXXX") || { echo "skipped: cannot make a folder in ${TMPDIR:-/tmp}"; exit 77; }
cleanup() {
  "$cluster" stop "$dir" >/dev/null 2>&1
  rm -rf "$dir"
}
trap cleanup EXIT
fail() {
  echo "FAILED: $*"
  for f in "$work"/staged/slurm/logs/*.out "$dir"/log/slurmctld.log; do [ -f "$f" ] && { echo "== $f"; tail -n 8 "$f"; }; done
  exit 1
}

"$make_scene" "$work/scene" --image-size 480x360 --images-per-epoch 1x2 --seed 1 >/dev/null 2>&1 || fail "make_scene"
for attempt in 1 2 3; do
  out=$("$cluster" start "$dir" 2>&1) && break
  if [ "$attempt" = 3 ] || ! grep -qiE "in use" <<<"$out"; then
    echo "skipped: ${out#slurm_cluster: cannot start: }"
    exit 77
  fi
done
# shellcheck disable=SC1091
source "$dir/env"

options=(--adjust --quiet)
"$match_epochs" "$work/scene/e1" "$work/scene/e2" --out "$work/whole" --threads 2 "${options[@]}" >/dev/null 2>&1 ||
  fail "the one-process run"
plan=$("$match_epochs" plan "$work/scene/e1" "$work/scene/e2" --out "$work/staged" "${options[@]}" --emit slurm \
         --slurm-max-array 2 2>&1) || fail "plan --emit slurm: $plan"
jobs=$(sed -n 's/^plan: \([0-9]*\) pair jobs.*/\1/p' <<<"$plan")
[ -n "$jobs" ] && [ "$jobs" -ge 3 ] || fail "the plan has '$jobs' jobs; the test wants 3 or more (two arrays)"
submitted=$(sh "$work/staged/slurm/submit.sh" 2>&1) || fail "submit.sh: $submitted"
ids=$(sed -n 's/.*: job \([0-9]*\)$/\1/p' <<<"$submitted" | tr '\n' ' ')
arrays=$(grep -c '^pairs ' <<<"$submitted")
[ "$arrays" -ge 2 ] || fail "$jobs jobs at 2 per array were submitted as $arrays array(s): $submitted"
# shellcheck disable=SC2086
report=$("$cluster" wait --timeout 600 $ids) || fail "the jobs did not all complete: $report"
echo "Slurm: $jobs pair jobs in $arrays arrays, then the merge: all COMPLETED"
cmake -DA="$work/whole" -DB="$work/staged" -DWHAT="Slurm plan / arrays / merge against the one-process run" \
      -P "$root/tests/support/same_results.cmake" || fail "the outputs differ"
echo "outputs byte for byte those of the one-process run"

#!/usr/bin/env bash
# The demo: the whole of Algorithm 1 (the paper's combined processing) on a decades-apart synthetic
# scene generated on the fly, through the programs users run (docs/adjustment.md, "The demo"):
#   1. make_scene --preset decades: two epochs decades apart over one terrain (or N with --epochs N),
#      each as its SfM would deliver it (images, a COLMAP text model, a DSM), in its own arbitrary
#      frame; the truth apart;
#   2. match_epochs --adjust: rough co-registration from the DSMs, overlapping pairs, precise matching,
#      then the combined adjustment (the last epoch fixed, the others self-calibrated, Fraser +
#      affine), and the DoD maps;
#   3. score_epochs: the paper's table, against the truth.
# Usage: scripts/demo.sh [--seed N] [--epochs N] [--out DIR] [--threads N]. --out keeps the scene and
# every output there (pictures included); without it they go to a temporary folder removed at the end.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seed=0
out=""
threads=0
epochs=2
while [ $# -gt 0 ]; do
  case "$1" in
    --seed) seed=${2:?--seed needs a value}; shift 2 ;;
    --out) out=${2:?--out needs a folder}; shift 2 ;;
    --threads) threads=${2:?--threads needs a value}; shift 2 ;;
    --epochs) epochs=${2:?--epochs needs a value}; shift 2 ;;
    *) echo "usage: scripts/demo.sh [--seed N] [--epochs N] [--out DIR] [--threads N]" >&2; exit 1 ;;
  esac
done

"$root/scripts/install_deps.sh"
build="$root/build/release"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$(nproc)" --target make_scene match_epochs score_epochs
bin="$build/examples"

keep=$out
if [ -z "$out" ]; then
  out=$(mktemp -d "${TMPDIR:-/tmp}/diachron_demo.XXXXXX")
  trap 'rm -rf "$out"' EXIT
elif [ -e "$out/scene" ] || [ -e "$out/result" ]; then
  echo "demo: $out already holds a scene/ or result/ folder; choose another --out" >&2
  exit 1
else
  mkdir -p "$out"
fi
threads_flag=()
[ "$threads" != 0 ] && threads_flag=(--threads "$threads")

start=$SECONDS
echo "== 1. make_scene --preset decades --epochs $epochs --seed $seed"
t=$SECONDS
"$bin/make_scene" "$out/scene" --preset decades --epochs "$epochs" --seed "$seed" "${threads_flag[@]}"
folders=()
for ((e = 1; e <= epochs; ++e)); do folders+=("$out/scene/e$e"); done
echo "   ($((SECONDS - t)) s)"

echo "== 2. match_epochs --adjust (rough co-registration, precise matching, combined adjustment)"
t=$SECONDS
status=0
"$bin/match_epochs" "${folders[@]}" --out "$out/result" --adjust "${threads_flag[@]}" || status=$?
echo "   ($((SECONDS - t)) s)"
if [ "$status" != 0 ]; then
  echo "demo: match_epochs stopped with exit status $status (the reason is above)" >&2
  exit "$status"
fi

echo "== 3. score_epochs: against the truth"
"$bin/score_epochs" "$out/scene" "$out/result"
echo
echo "total $((SECONDS - start)) s"
[ -n "$keep" ] && echo "the scene is in $out/scene, match_epochs' outputs (tie points, pictures, adjusted/, dod/) in $out/result"
exit 0

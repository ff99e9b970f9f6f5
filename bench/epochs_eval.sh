#!/usr/bin/env bash
# epochs_eval: Algorithm 1 with three epochs (make_scene --preset decades --epochs 3: films of the
# 1960s and 1980s, a recent reference e3), per seed, judged with the scene's truth by score_epochs:
#   joint     match_epochs e1 e2 e3 --adjust: every pair matched, one adjustment
#   pairwise  match_epochs e1 e3 --adjust and match_epochs e2 e3 --adjust (the two-epoch way), with
#             the joint run's rough transforms given (--rough FILE), so only the matching of e1 -- e2
#             and the adjustment differ
# Prints per seed and free epoch the check points' 3D RMS (metres, and in the epoch's GSD): rough
# only, pairwise, joint; the tracks tying the epoch directly to the reference and to the other film;
# the DoD's placement error (median |DoD - DoD with the true placement|, reference units) rough and
# joint; and (on stderr) the wall time and peak memory of the joint run and of each pairwise run.
#
#   bench/epochs_eval.sh BUILD_DIR WORK_DIR [SEED ...]     (default seeds 0 1 2 3 4; about 8 min each
#                                                          on 2 cores)
# With SCORE_ONLY=1 in the environment the runs already in WORK_DIR are scored again, not repeated.
set -euo pipefail
build=${1:?usage: epochs_eval.sh BUILD_DIR WORK_DIR [SEED ...]}
work=${2:?usage: epochs_eval.sh BUILD_DIR WORK_DIR [SEED ...]}
shift 2
seeds=("$@")
[ ${#seeds[@]} -gt 0 ] || seeds=(0 1 2 3 4)
make_scene=$build/examples/make_scene
match=$build/examples/match_epochs
score=$build/examples/score_epochs
for tool in "$make_scene" "$match" "$score"; do
  [ -x "$tool" ] || { echo "epochs_eval: $tool is not built" >&2; exit 2; }
done
mkdir -p "$work"

# run NAME COMMAND...: runs a command under GNU time, its output in NAME.log, "seconds KB" in NAME.time.
run() {
  local name=$1
  shift
  /usr/bin/time -f "%e %M" -o "$work/$name.time" "$@" > "$work/$name.log" 2>&1 || true
}
# cost NAME: "seconds s, MB MB" of a timed run.
cost() { [ -f "$work/$1.time" ] && awk '{printf "%.0f s, %.0f MB", $1, $2 / 1024}' "$work/$1.time" || echo "not timed"; }
# rms LOG EPOCH: "rough pipeline pipeline_gsd", the 3D RMS of EPOCH in score_epochs' output.
rms() { sed -n "s/^3D RMS of $2: rough only \([0-9.]*\) m (\([0-9.]*\) GSD.*full pipeline \([0-9.]*\) m (\([0-9.]*\) GSD.*/\1 \3 \4/p" "$1"; }
placement() { sed -n "s/^DoD of $2, error of the placement against the true one (reference units): rough median \([0-9.na-]*\), RMS [0-9.na-]*; adjusted median \([0-9.na-]*\).*/\1 \2/p" "$1"; }
links() { # links REPORT A B: tracks tying epochs A and B in report.json
  grep -o "{\"epochs\": \[\"$2\", \"$3\"\], \"tracks\": [0-9]*}" "$1" | grep -o '[0-9]*}$' | tr -d '}'
}

echo "| seed | epoch | rough only m | pairwise m | joint m | joint GSD | ties with e3 | ties with other film | DoD placement rough | DoD placement joint |"
echo "|------|-------|--------------|------------|---------|-----------|--------------|---------------------|---------------------|---------------------|"
for seed in "${seeds[@]}"; do
  scene=$work/scene$seed
  [ -f "$scene/truth/scene.txt" ] || "$make_scene" "$scene" --preset decades --epochs 3 --seed "$seed" > "$work/scene$seed.log" 2>&1
  out=$work/joint$seed
  if [ -z "${SCORE_ONLY:-}" ]; then
    rm -rf "$out" "$work/pair13_$seed" "$work/pair23_$seed"
    run joint$seed "$match" "$scene/e1" "$scene/e2" "$scene/e3" --out "$out" --adjust --no-pictures --quiet > /dev/null
    run pair13_$seed "$match" "$scene/e1" "$scene/e3" --out "$work/pair13_$seed" --adjust --no-pictures --quiet \
        --rough "$out/rough_helmert_e1.json" > /dev/null
    run pair23_$seed "$match" "$scene/e2" "$scene/e3" --out "$work/pair23_$seed" --adjust --no-pictures --quiet \
        --rough "$out/rough_helmert_e2.json"
  fi
  joint=$(cost joint$seed)
  pair13=$(cost pair13_$seed)
  pair23=$(cost pair23_$seed)
  "$score" "$scene" "$out" > "$work/score_joint$seed.txt" 2>&1 || true
  "$score" "$scene" "$work/pair13_$seed" > "$work/score_pair13_$seed.txt" 2>&1 || true
  "$score" "$scene" "$work/pair23_$seed" > "$work/score_pair23_$seed.txt" 2>&1 || true
  for e in e1 e2; do
    pair=$([ $e = e1 ] && echo pair13_$seed || echo pair23_$seed)
    read -r rough joint_m joint_gsd <<< "$(rms "$work/score_joint$seed.txt" $e || true)"
    read -r _ pair_m _ <<< "$(rms "$work/score_$pair.txt" $e || true)"
    read -r place_rough place_joint <<< "$(placement "$work/score_joint$seed.txt" $e || true)"
    ref_links=$(links "$out/report.json" $e e3 || true)
    film_links=$(links "$out/report.json" e1 e2 || true)
    echo "| $seed | $e | ${rough:-?} | ${pair_m:-failed} | ${joint_m:-failed} | ${joint_gsd:-?} | ${ref_links:-0} | ${film_links:-0} | ${place_rough:-?} | ${place_joint:-?} |"
  done
  echo "seed $seed: joint e1 e2 e3 $joint; pairwise e1 e3 $pair13, e2 e3 $pair23" >&2
done

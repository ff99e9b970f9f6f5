#!/usr/bin/env bash
# The input checks and the trust of match_epochs (issue 47) on the decades scenes, per seed:
#   - the scene as make_scene writes it: match_epochs --adjust --check-points, its verdicts (model
#     against DSM per epoch), its trust and reasons, e1's check points (a false alarm shows here);
#   - the same scene with e1's model moved against its DSM (make_scene --model-offset, epoch-1 units):
#     130 up (the COLMAP case of the issue), 25 / -15 sideways, both, and 13 up (about 1.5 of e1's
#     tolerance): match_epochs' exit status and the first refusal or warning;
#   - with OLD_BUILD=DIR, the same plain run by that build's match_epochs: Homol/ and adjusted/<epoch>/
#     compared byte for byte (the results before the checks were added).
# Usage: bench/input_checks_eval.sh BUILD_DIR WORK_DIR [SEED ...]   (seeds 0-4 by default)
set -euo pipefail
build=$(cd "$1" && pwd)
work=$2
shift 2
seeds=("$@")
[ ${#seeds[@]} -gt 0 ] || seeds=(0 1 2 3 4)
mkdir -p "$work"
work=$(cd "$work" && pwd)
make_scene="$build/examples/make_scene"
match="$build/examples/match_epochs"

# first_finding LOG: the first refusal or warning line of a match_epochs log, shortened.
first_finding() {
  grep -m1 -E "^match_epochs: epoch|^warning:" "$1" | cut -c1-230 || true
}

# report_field REPORT PYTHON_EXPRESSION: a value of report.json (r is the parsed report).
report_field() {
  python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print($2)" "$1"
}

echo "| seed | case | exit | e1 model vs DSM | trust | reasons | e1 check points 3D RMS rough -> adjusted | first finding |"
echo "|---|---|---|---|---|---|---|---|"
for seed in "${seeds[@]}"; do
  scene="$work/s$seed"
  [ -d "$scene/e1" ] || "$make_scene" "$scene" --preset decades --seed "$seed" --control-points 10 > /dev/null
  out="$work/s${seed}_out"
  rm -rf "$out"
  set +e
  "$match" "$scene/e1" "$scene/e2" --out "$out" --adjust --check-points "$scene/check_points.txt" --threads 2 \
    > "$work/s${seed}.log" 2>&1
  status=$?
  set -e
  verdict=$(report_field "$out/report.json" "r['input_checks']['e1']['model_dsm']['verdict']")
  trust=$(report_field "$out/report.json" "r['trust']['level']")
  reasons=$(report_field "$out/report.json" "'; '.join(r['trust']['reasons']) or '-'")
  rms=$(report_field "$out/report.json" \
    "'%.3f -> %.3f' % (r['adjustment']['check_points']['e1']['rough']['rms_3d'], r['adjustment']['check_points']['e1']['adjusted']['rms_3d'])")
  echo "| $seed | as made | $status | $verdict | $trust | $reasons | $rms | $(first_finding "$work/s${seed}.log") |"
  if [ -n "${OLD_BUILD:-}" ]; then
    old="$work/s${seed}_old"
    rm -rf "$old"
    "$OLD_BUILD/examples/match_epochs" "$scene/e1" "$scene/e2" --out "$old" --adjust \
      --check-points "$scene/check_points.txt" --threads 2 --quiet > "$work/s${seed}_old.log" 2>&1 || true
    same="same"
    diff -r "$old/Homol" "$out/Homol" > /dev/null || same="Homol/ DIFFERS"
    for e in e1 e2; do diff -r "$old/adjusted/$e" "$out/adjusted/$e" > /dev/null || same="$same, adjusted/$e DIFFERS"; done
    cmp -s "$old/adjusted/cameras.json" "$out/adjusted/cameras.json" || same="$same, cameras.json DIFFERS"
    echo "| $seed | against the build before | | | | | | $same |"
  fi
  for offset in "0,0,130" "25,-15,0" "25,-15,130" "0,0,13"; do
    moved="$work/s${seed}_$(echo "$offset" | tr ',' '_')"
    [ -d "$moved/e1" ] || "$make_scene" "$moved" --preset decades --seed "$seed" --control-points 10 \
      --model-offset "e1=$offset" > /dev/null
    mout="${moved}_out"
    rm -rf "$mout"
    set +e
    "$match" "$moved/e1" "$moved/e2" --out "$mout" --adjust --check-points "$moved/check_points.txt" --threads 2 \
      > "$moved.log" 2>&1
    status=$?
    set -e
    if [ -f "$mout/report.json" ]; then
      verdict=$(report_field "$mout/report.json" "r['input_checks']['e1']['model_dsm']['verdict']")
      trust=$(report_field "$mout/report.json" "r['trust']['level']")
      reasons=$(report_field "$mout/report.json" "'; '.join(r['trust']['reasons']) or '-'" | cut -c1-160)
      rms=$(report_field "$mout/report.json" \
        "'%.3f -> %.3f' % (r['adjustment']['check_points']['e1']['rough']['rms_3d'], r['adjustment']['check_points']['e1']['adjusted']['rms_3d'])" \
        2> /dev/null || echo "-")
    else
      verdict="-"; trust="-"; reasons="-"; rms="-"
    fi
    echo "| $seed | e1 model moved ($offset) | $status | $verdict | $trust | $reasons | $rms | $(first_finding "$moved.log") |"
  done
done

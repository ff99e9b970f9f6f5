#!/usr/bin/env bash
# The Time-SIFT peer: Debian's COLMAP (3.8, CPU only) on the union of both epochs' images of a scene
# written by write_scene (make_scene), as one SfM problem. Says whether the mapper merges the epochs
# into one model, and scores COLMAP's inter-epoch matches against the scene's truth.
#
# Usage: bench/peers/colmap_timesift.sh SCENE_DIR WORK_DIR
#   SCENE_DIR  a scene folder (OUT/<epoch>/images/*.png, OUT/truth/scene.txt)
#   WORK_DIR   created if needed; holds images/ (links), database.db, sparse/, the exported tables
# Environment: COLMAP (binary, default colmap), COLMAP_CAMERA_MODEL (default SIMPLE_RADIAL, COLMAP's
# default), COLMAP_THREADS (default 2), DIACHRON_BUILD (default build/release: where
# bench/colmap_matches_score is).
#
# Steps: feature_extractor with one camera per folder (= per epoch: one scanned film camera each),
# exhaustive_matcher, mapper; every model converted to text; the database's images, keypoints,
# matches and two_view_geometries exported with sqlite3 as text (blobs in hex); then
# colmap_matches_score reads the scene with read_scene and scores every match with MatchTruthScorer.
# Not a test: COLMAP runs take a minute even on small scenes.
set -euo pipefail

if [ $# -ne 2 ]; then
  echo "usage: $0 SCENE_DIR WORK_DIR" >&2
  exit 1
fi
root=$(cd "$(dirname "$0")/../.." && pwd)
scene=$(cd "$1" && pwd)
mkdir -p "$2"
work=$(cd "$2" && pwd)
colmap=${COLMAP:-colmap}
camera_model=${COLMAP_CAMERA_MODEL:-SIMPLE_RADIAL}
threads=${COLMAP_THREADS:-2}
build=${DIACHRON_BUILD:-$root/build/release}
score="$build/bench/colmap_matches_score"

command -v "$colmap" >/dev/null || { echo "colmap_timesift: '$colmap' not found (scripts/install_deps.sh --peers installs it)" >&2; exit 1; }
command -v sqlite3 >/dev/null || { echo "colmap_timesift: sqlite3 not found (scripts/install_deps.sh --peers installs it)" >&2; exit 1; }
[ -x "$score" ] || { echo "colmap_timesift: $score not built (cmake --build $build --target colmap_matches_score)" >&2; exit 1; }
[ -f "$scene/truth/scene.txt" ] || { echo "colmap_timesift: $scene/truth/scene.txt not found: not a scene folder" >&2; exit 1; }

# The epochs, in the truth's order; each one's images go into their own folder (one camera each).
mapfile -t epochs < <(awk '$1 == "epoch" { print $2 }' "$scene/truth/scene.txt")
rm -rf "$work/images" "$work/sparse" "$work/sparse_txt" "$work/database.db"
mkdir -p "$work/images" "$work/sparse" "$work/sparse_txt"
for e in "${epochs[@]}"; do
  mkdir -p "$work/images/$e"
  for f in "$scene/$e/images/"*.png; do ln -s "$f" "$work/images/$e/"; done
done

log="$work/colmap.log"
: > "$log"
run() {
  echo "== colmap $1" | tee -a "$log"
  local t0=$SECONDS
  "$colmap" "$@" >> "$log" 2>&1 || { echo "colmap $1 failed, see $log" >&2; exit 1; }
  echo "   $((SECONDS - t0)) s" | tee -a "$log"
}
run feature_extractor --database_path "$work/database.db" --image_path "$work/images" \
  --ImageReader.single_camera_per_folder 1 --ImageReader.camera_model "$camera_model" \
  --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads "$threads"
run exhaustive_matcher --database_path "$work/database.db" --SiftMatching.use_gpu 0 \
  --SiftMatching.num_threads "$threads"
run mapper --database_path "$work/database.db" --image_path "$work/images" --output_path "$work/sparse" \
  --Mapper.num_threads "$threads"
for m in "$work/sparse"/*/; do
  [ -d "$m" ] || continue
  n=$(basename "$m")
  mkdir -p "$work/sparse_txt/$n"
  run model_converter --input_path "$m" --output_path "$work/sparse_txt/$n" --output_type TXT
done

# The database as text: blobs in hex (keypoints float32 rows x cols, x y first, COLMAP pixels;
# matches uint32 rows x 2; pair_id = image_id1 * 2147483647 + image_id2).
db="$work/database.db"
sqlite3 -separator ' ' "$db" "select image_id, camera_id, name from images order by image_id" > "$work/db_images.txt"
sqlite3 -separator ' ' "$db" "select image_id, rows, cols, hex(data) from keypoints where rows > 0" > "$work/db_keypoints.txt"
sqlite3 -separator ' ' "$db" "select pair_id, rows, cols, hex(data) from matches where rows > 0" > "$work/db_matches.txt"
sqlite3 -separator ' ' "$db" \
  "select pair_id, rows, cols, config, hex(data) from two_view_geometries where rows > 0" > "$work/db_two_view_geometries.txt"

echo "== scoring"
"$score" "$scene" "$work" --json "$work/colmap_timesift.json"

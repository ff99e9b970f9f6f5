#!/usr/bin/env bash
# Builds the test programs of the multi-threaded code (terrain/, pipeline/) with ThreadSanitizer and
# runs the tests that use threads: the DSM correlation search, the rough co-registration and the
# precise matching. Not part of CI (a TSan build of two test programs takes a few minutes, and the
# system's OpenCV, TBB and GDAL are not instrumented: their internals are suppressed in
# tests/support/tsan.supp, so only races in diachron's own code are reported).
# Usage: scripts/tsan.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh"
build="$root/build/tsan"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE= -DCMAKE_CXX_FLAGS="-O1 -fsanitize=thread" \
      -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread -DDIACHRON_BUILD_EXAMPLES=OFF -DDIACHRON_BUILD_BENCH=OFF >/dev/null
cmake --build "$build" -j "$(nproc)" --target test_terrain test_pipeline
export TSAN_OPTIONS="halt_on_error=1 suppressions=$root/tests/support/tsan.supp"
run() {  # PROGRAM FILE_TAG: one test file's cases (the tag quoted: [#...] is a glob pattern unquoted)
  echo "== $1 $2"
  "$build/tests/$1" "$2" "-#"
}
run test_terrain "[#dsm_correlation_search_test]"
run test_pipeline "[#rough_coregistration_test]"
run test_pipeline "[#precise_matching_test]"

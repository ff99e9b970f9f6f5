#!/usr/bin/env bash
# Builds and runs every test twice: a Release build (with examples and the installed-package consumer
# test; the benchmarks only on request) and an ASan + UBSan build. Usage: scripts/test.sh [--no-sanitize]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh" --peers
# Slurm and munge for the cluster tests (tests/support/slurm_smoke.sh, match_epochs_slurm.sh: each
# starts its own single-node cluster in a temporary folder and stops it; skipped, with the reason,
# when it cannot start).
"$root/scripts/slurm_cluster.sh" install || echo "diachron: Slurm could not be installed; the Slurm tests are skipped"
jobs=$(nproc)
sanitize=1
[ "${1:-}" = "--no-sanitize" ] && sanitize=0

echo "== Release build and tests"
# The benchmarks are configured but not built here: each instantiates the whole pipeline (about a
# minute of compiler time apiece, a quarter of a CI run for the dozen of them). Build one with
# cmake --build build/release --target NAME (docs/benchmarks.md).
# The test programs at -O1, the examples at -O3 (why: DIACHRON_TEST_COMPILE_OPTIONS in tests/CMakeLists.txt).
# headers/alone without its link check: -fkeep-inline-functions doubles each building block's
# compile, and without it the test took 434 s instead of 560 on a 2-core machine where this whole
# script took 32 minutes with it. The compile check of every header stays. Run the link check
# before changing a building block's includes: cmake -B build/release -DDIACHRON_TEST_HEADERS_LINK=ON,
# then ctest -R headers/alone.
cmake -S "$root" -B "$root/build/release" -DCMAKE_BUILD_TYPE=Release -DDIACHRON_BENCH_IN_ALL=OFF \
      -DDIACHRON_TEST_COMPILE_OPTIONS=-O1 -DDIACHRON_TEST_HEADERS_LINK=OFF >/dev/null
cmake --build "$root/build/release" -j "$jobs"
ctest --test-dir "$root/build/release" --output-on-failure -j "$jobs"

if [ "$sanitize" = 1 ]; then
  echo "== ASan + UBSan build and tests"
  # -Og without debug info: 30 % less compile time than -O1 (the compile is most of a CI run) for
  # tests that run about 1.5x longer; the sanitizers see the same code. Reports still name the
  # functions.
  cmake -S "$root" -B "$root/build/sanitize" -DCMAKE_BUILD_TYPE= -DCMAKE_CXX_FLAGS=-Og -DDIACHRON_SANITIZE=ON \
        -DDIACHRON_BUILD_EXAMPLES=OFF -DDIACHRON_BUILD_BENCH=OFF >/dev/null
  cmake --build "$root/build/sanitize" -j "$jobs"
  ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --test-dir "$root/build/sanitize" --output-on-failure -j "$jobs"
fi

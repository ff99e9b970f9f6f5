#!/usr/bin/env bash
# Builds everything but the benchmarks with clang++ (warnings are errors), runs every test, and checks
# that a clang build makes the same synthetic scene as the GCC build, byte for byte (images, DSMs,
# models, truth): the same seed must give the same data whatever the compiler (docs/conventions.md,
# "Randomness and threads"). Not part of CI: the second build and test run took 7 minutes on 2 cores
# (the CI run takes 16). Installs clang when it is missing.
# Usage: scripts/clang.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh" --clang
jobs=$(nproc)

echo "== clang build (warnings are errors) and tests"
cmake -S "$root" -B "$root/build/clang" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_FLAGS=-Werror -DDIACHRON_BENCH_IN_ALL=OFF -DDIACHRON_TEST_COMPILE_OPTIONS=-O1 \
      -DDIACHRON_TEST_HEADERS_LINK=OFF >/dev/null
cmake --build "$root/build/clang" -j "$jobs"
ctest --test-dir "$root/build/clang" --output-on-failure -j "$jobs"

echo "== the same scene from GCC and from clang"
cmake -S "$root" -B "$root/build/release" -DCMAKE_BUILD_TYPE=Release -DDIACHRON_BENCH_IN_ALL=OFF \
      -DDIACHRON_TEST_COMPILE_OPTIONS=-O1 -DDIACHRON_TEST_HEADERS_LINK=OFF >/dev/null
cmake --build "$root/build/release" -j "$jobs" --target make_scene
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for compiler in release clang; do
  "$root/build/$compiler/examples/make_scene" "$work/$compiler" --preset decades --seed 1 >/dev/null
done
if diff -r "$work/release" "$work/clang" >/dev/null; then
  echo "the decades scene of seed 1 is the same from both compilers ($(find "$work/clang" -type f | wc -l) files)"
else
  echo "the decades scene of seed 1 differs between GCC and clang:"
  diff -rq "$work/release" "$work/clang" | head -20
  exit 1
fi

#!/usr/bin/env bash
# Builds the examples and runs the demo. Until the full pipeline lands, the demo is the estimator
# example: robust Similarity2 / Helmert3 estimation with two different RANSAC policy sets.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh"
build="$root/build/release"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$(nproc)" --target estimators
"$build/examples/estimators" "$@"

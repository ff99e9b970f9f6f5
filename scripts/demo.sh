#!/usr/bin/env bash
# Builds the examples and runs the demo: a synthetic two-epoch scene generated on the fly, its rough
# co-registration from the DSMs, and the check-point errors against the truth (examples/demo.cpp).
# Extra arguments go to the demo (e.g. --seed 3 --out /tmp/scene).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install_deps.sh"
build="$root/build/release"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$(nproc)" --target demo
"$build/examples/demo" "$@"

#!/usr/bin/env bash
# The README's test command: install dependencies, build everything, run every test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./deploy/install-deps.sh
build_dir=${MAPDELTA_BUILD_DIR:-build}
jobs=${MAPDELTA_JOBS:-$(nproc)}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build_dir" -j "$jobs"
ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" --timeout 900

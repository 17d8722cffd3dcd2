#!/usr/bin/env bash
# The README's test command: install dependencies, build everything, run every test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./deploy/install-deps.sh
build_dir=${MAPDELTA_BUILD_DIR:-build}
jobs=${MAPDELTA_JOBS:-$(nproc)}
# Paths relative to the checkout let ccache reuse objects across clones (CI builds a fresh one).
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build_dir" -j "$jobs"
ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" --timeout 900

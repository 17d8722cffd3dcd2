#!/usr/bin/env bash
# The README's test command: install dependencies, build everything, run every test suite.
#   bash tools/run-tests.sh              what CI runs (Release build in build/)
#   bash tools/run-tests.sh --sanitize   the same suites built with ASan + UBSan in build-asan/
#                                        (any report fails the test that triggered it)
#   bash tools/run-tests.sh --tsan       the threaded suites (GICP worker team, commit passes,
#                                        bounded queues, uploader, VIO pipeline) with TSan in build-tsan/
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-}
case $mode in
  "" | --sanitize | --tsan) ;;
  *) echo "usage: tools/run-tests.sh [--sanitize | --tsan]" >&2; exit 2 ;;
esac
./deploy/install-deps.sh
jobs=${MAPDELTA_JOBS:-$(nproc)}
# Paths relative to the checkout let ccache reuse objects across clones (CI builds a fresh one).
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
ctest_args=(--output-on-failure -j "$jobs" --timeout 900)
case $mode in
  "")
    build_dir=${MAPDELTA_BUILD_DIR:-build}
    cmake_args=()
    ;;
  --sanitize)
    build_dir=${MAPDELTA_BUILD_DIR:-build-asan}
    cmake_args=(-DMAPDELTA_SANITIZE=ON)
    # halt_on_error: a UBSan report fails the test instead of scrolling by; leaks are reported.
    export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}
    export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
    ;;
  --tsan)
    build_dir=${MAPDELTA_BUILD_DIR:-build-tsan}
    cmake_args=(-DMAPDELTA_SANITIZE_THREAD=ON -DMAPDELTA_BUILD_BENCH=OFF)
    # Exported before the build too: test discovery runs each binary at build time.
    export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/tools/sanitizers/tsan.supp}
    # Every loop of ours runs on common/parallel.hpp's std::threads, which TSan sees. GCC's
    # libgomp is not built with TSan (its barriers look like races): a library's OpenMP, if
    # any, runs on one thread here.
    export OMP_NUM_THREADS=1
    ctest_args+=(-R "${MAPDELTA_TSAN_TESTS:-SameResultForAnyThreadCount|Parallel|ChangeDetection|ObservedArea|CommitPaths|DecodeAhead|Upload|Pipelined|ServerHttpTest|ServerProcessTest|MapService}")
    ;;
esac
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "${cmake_args[@]}" >/dev/null
cmake --build "$build_dir" -j "$jobs"
ctest --test-dir "$build_dir" "${ctest_args[@]}"

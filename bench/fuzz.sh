#!/usr/bin/env bash
# Coverage-guided fuzzing of every decoder of outside input (tests/fuzz/): builds the targets
# with clang + libFuzzer + ASan + UBSan in their own build folder and runs each one for the
# given seconds, one after another at nice 19. Prints per target: executions, coverage (cov:
# edges, ft: features), corpus size and findings. Exit status 1 if any target found a crash.
#   bash bench/fuzz.sh [seconds per target, default 60] [target ...]
# Env: MAPDELTA_FUZZ_TIMEOUT (seconds per input, default 10), MAPDELTA_FUZZ_NO_BUILD=1.
# Findings land in build-fuzz/findings/<target>/; copy one into tests/fuzz/regressions/<target>/
# once it is fixed, so that the normal build's replay test keeps it fixed.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang++-14 >/dev/null || { echo "bench/fuzz.sh needs clang-14 and libclang-rt-14-dev (apt-get install)" >&2; exit 2; }
seconds=${1:-60}
shift || true
build=${MAPDELTA_FUZZ_BUILD_DIR:-build-fuzz}
export CCACHE_BASEDIR=$PWD
if [ "${MAPDELTA_FUZZ_NO_BUILD:-0}" != 1 ]; then  # 1: runs beside another fuzz.sh use its build
  CC=clang-14 CXX=clang++-14 cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DMAPDELTA_FUZZ=ON -DMAPDELTA_BUILD_BENCH=OFF >/dev/null
  # The shared build lock only when there is something to build.
  if ! cmake --build "$build" --target fuzz_all -- -n 2>/dev/null | grep -q 'no work to do'; then
    flock /tmp/mapdelta-build.lock nice -n 19 cmake --build "$build" --target fuzz_all -j 2
  fi
fi
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  mapfile -t targets < <(cd tests/fuzz && ls fuzz_*.cpp | sed 's/\.cpp$//')
fi
printf '%-20s %12s %10s %8s %8s %8s %s\n' target executions exec/s cov ft corpus findings
failed=0
for t in "${targets[@]}"; do
  work="$build/corpus/$t" findings="$build/findings/$t" log="$build/logs/$t.log"
  mkdir -p "$work" "$findings" "$(dirname "$log")"
  seeds=(tests/fuzz/corpus/"$t")
  [ -d tests/fuzz/regressions/"$t" ] && seeds+=(tests/fuzz/regressions/"$t")
  # -rss_limit_mb / -malloc_limit_mb: an input that makes a decoder allocate more than 2 GiB is
  # a finding (a size taken from a header unchecked), not a reason to swap. -timeout is wall
  # time: on a machine loaded far beyond its cores a nice-19 fuzzer can stall for a minute on a
  # 2 ms input (seen 2026-12-03), so raise MAPDELTA_FUZZ_TIMEOUT there, and replay any timeout
  # alone before calling it a hang.
  set +e
  nice -n 19 "$build/tests/fuzz/$t" -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=2048 \
    -timeout="${MAPDELTA_FUZZ_TIMEOUT:-10}" -print_final_stats=1 -artifact_prefix="$findings/" "$work" "${seeds[@]}" >"$log" 2>&1
  status=$?
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  found=$(find "$findings" -type f | wc -l)
  printf '%-20s %12s %10s %8s %8s %8s %s\n' "$t" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" \
    "$(find "$work" -type f | wc -l)" "$found (exit $status, log $log)"
  if [ "$status" -ne 0 ] || [ "$found" -ne 0 ]; then failed=1; fi
done
exit $failed

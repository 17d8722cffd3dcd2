#!/usr/bin/env bash
# Crash soak on loopback: the same upload workload twice against fresh servers. First
# uninterrupted (the reference); then with --kills random SIGKILLs of the server while vehicles
# upload and commit, each followed by a restart on the same port (the load driver retries
# whatever got no answer). Passes if every acknowledged keyframe is stored, every commit
# succeeded, PRAGMA integrity_check says ok on both databases, and the changed tiles (counts
# and confidence per tile) equal the reference's.
#   bash bench/crash_soak.sh [--kills N (50)] [--seed S (1)] [--min-ms A (100)] [--max-ms B (700)]
#                            [load options, defaults --uploaders 4 --keyframes 500 --session-keyframes 50]
# Env: MAPDELTA_BUILD_DIR (default build), MAPDELTA_KEEP=1 keeps the temp folder.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${MAPDELTA_BUILD_DIR:-build}
kills=50 seed=1 min_ms=100 max_ms=700
load=(--uploaders 4 --keyframes 500 --session-keyframes 50 --readers 1 --reader-interval-ms 100)
while [ $# -gt 0 ]; do
  case $1 in
    --kills) kills=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --min-ms) min_ms=$2; shift 2 ;;
    --max-ms) max_ms=$2; shift 2 ;;
    *) load+=("$1"); shift ;;
  esac
done
source bench/server_fixture.sh
md_ensure_built
root=$(mktemp -d /tmp/mapdelta-soak.XXXXXX)
driver_pid=""
cleanup() {
  [ -n "$driver_pid" ] && kill "$driver_pid" 2>/dev/null || true
  md_server_stop KILL || true
  if [ "${MAPDELTA_KEEP:-0}" = 1 ]; then echo "kept $root"; else rm -rf "$root"; fi
}
trap cleanup EXIT

run_driver() {  # extra bench_load options...
  "$build/bench/bench_load" --port "$MD_PORT" --vehicle-token "$(cat "$dir/vehicle.token")" \
    --reader-token "$(cat "$dir/reader.token")" --server-pid-file "$dir/server.pid" "${load[@]}" "$@"
}

integrity() { sqlite3 "$dir/db.sqlite" 'PRAGMA integrity_check;'; }

echo "== reference run (no kills)"
dir=$root/reference
md_server_setup
md_server_start 0
run_driver --dump-changes "$dir/changes.txt" >"$dir/driver.out" || { cat "$dir/driver.out"; exit 1; }
md_server_stop TERM
grep -E '^(acknowledged|sessions|RESULT)' "$dir/driver.out"
reference_integrity=$(integrity)

echo "== soak run: $kills SIGKILLs, every ${min_ms}-${max_ms} ms (seed $seed)"
dir=$root/soak
md_server_setup
md_server_start 0
port=$MD_PORT
run_driver --retry --dump-changes "$dir/changes.txt" >"$dir/driver.out" &
driver_pid=$!
RANDOM=$seed
done_kills=0 restart_ms_total=0
while [ "$done_kills" -lt "$kills" ] && kill -0 "$driver_pid" 2>/dev/null; do
  sleep "$(awk -v ms=$((min_ms + RANDOM % (max_ms - min_ms + 1))) 'BEGIN { printf "%.3f", ms / 1000 }')"
  md_server_stop KILL || true
  done_kills=$((done_kills + 1))
  t0=$(date +%s%N)
  md_server_start "$port"
  restart_ms_total=$((restart_ms_total + ($(date +%s%N) - t0) / 1000000))
done
status=0
wait "$driver_pid" || status=$?
driver_pid=""
md_server_stop TERM || { echo "server did not exit cleanly on SIGTERM after the soak" >&2; status=1; }
cat "$dir/driver.out" | sed -n '/^acknowledged/,$p'
soak_integrity=$(integrity)
echo
echo "kills: $done_kills of $kills (mean restart to listening: $((restart_ms_total / (done_kills > 0 ? done_kills : 1))) ms)"
[ "$done_kills" -eq "$kills" ] || { echo "the workload ended before all kills: raise --keyframes" >&2; status=1; }
echo "integrity_check: reference $reference_integrity, soak $soak_integrity"
[ "$reference_integrity" = ok ] && [ "$soak_integrity" = ok ] || status=1
echo "changed tiles: reference $(wc -l <"$root/reference/changes.txt"), soak $(wc -l <"$dir/changes.txt")"
[ -s "$root/reference/changes.txt" ] || { echo "the reference run found no changes: nothing to compare" >&2; status=1; }
if diff "$root/reference/changes.txt" "$dir/changes.txt" >"$root/changes.diff"; then
  echo "changes equal the uninterrupted run's"
else
  echo "changes DIFFER from the uninterrupted run's:"; head -20 "$root/changes.diff"; status=1
fi
echo "resumed jobs (server log): $(grep -c 'will resume' "$dir/server.log" || true)"
[ "$status" -eq 0 ] && echo "SOAK ok" || echo "SOAK FAILED"
exit $status

#!/usr/bin/env bash
# Load on loopback: a fresh mapdelta-server (temp folder, default config but for paths and
# 20 m tiles), 16 vehicle uploaders x 500 keyframes with a commit every 100 (configurable),
# readers of the change endpoints beside them. Prints keyframes/s, p50/p99 per endpoint,
# errors, the server's RSS over time, and fails if a keyframe is lost, a commit fails, the
# server answers 5xx or does not answer. Bounded: --max-seconds (default 900) for the uploads.
#   bash bench/load.sh [--uploaders N] [--keyframes N] [--session-keyframes N] [--readers N]
#                      [--reader-interval-ms MS] [--max-seconds S]
# Env: MAPDELTA_BUILD_DIR (default build), MAPDELTA_KEEP=1 keeps the temp folder.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${MAPDELTA_BUILD_DIR:-build}
source bench/server_fixture.sh
md_ensure_built
dir=$(mktemp -d /tmp/mapdelta-load.XXXXXX)
cleanup() {
  md_server_stop KILL || true
  if [ "${MAPDELTA_KEEP:-0}" = 1 ]; then echo "kept $dir"; else rm -rf "$dir"; fi
}
trap cleanup EXIT
md_server_setup
md_server_start 0
echo "server pid $MD_SERVER_PID on 127.0.0.1:$MD_PORT, folder $dir"
status=0
"$build/bench/bench_load" --port "$MD_PORT" --vehicle-token "$(cat "$dir/vehicle.token")" \
  --reader-token "$(cat "$dir/reader.token")" --server-pid-file "$dir/server.pid" "$@" || status=$?
md_server_stop TERM || { echo "server did not exit cleanly on SIGTERM" >&2; status=1; }
errors=$(grep -c '"level":"error"' "$dir/server.log" || true)
echo "server log: $errors error lines"
[ "$errors" -eq 0 ] || { grep '"level":"error"' "$dir/server.log" | head -5; status=1; }
exit $status

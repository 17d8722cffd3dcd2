# Sourced by bench/load.sh and bench/crash_soak.sh: a fresh mapdelta-server in a temp folder on
# loopback (config, vehicle/reader/admin tokens, the box-scene prior imported), started and
# stopped by pid. Expects $build (the build folder) and $dir (the run's folder) to be set.
server_bin() { echo "$build/server/mapdelta-server"; }

# Writes $dir/server.yaml and $dir/prior.pcd, creates the tokens and imports the prior.
# MAPDELTA_SERVER_YAML: more top-level config sections (e.g. "http:\n  observed_cache_bytes: 0").
md_server_setup() {
  mkdir -p "$dir"
  cat >"$dir/server.yaml" <<YAML
storage:
  database: $dir/db.sqlite
  tile_size_m: 20
log:
  level: ${MD_LOG_LEVEL:-warn}
  format: json
${MAPDELTA_SERVER_YAML:-}
YAML
  local role
  for role in vehicle reader admin; do
    "$(server_bin)" token create --config "$dir/server.yaml" --role "$role" --name "bench-$role" \
      | sed -n 's/^token: //p' >"$dir/$role.token"
    [ -s "$dir/$role.token" ] || { echo "token create ($role) failed" >&2; return 1; }
  done
  "$build/bench/bench_load" --write-prior "$dir/prior.pcd"
  "$(server_bin)" import-prior --config "$dir/server.yaml" --cloud "$dir/prior.pcd" >/dev/null 2>>"$dir/server.log"
}

# Starts the server on port $1 (0 = any free port); sets MD_PORT and writes $dir/server.pid.
# MAPDELTA_SERVER_WRAP (e.g. "heaptrack -o /tmp/load"): a command that runs the server as its
# child; server.pid (what the RSS sampler reads and the signals go to) is then that child's.
md_server_start() {
  local want=${1:-0} line=""
  rm -f "$dir/server.out"
  # shellcheck disable=SC2086  # the wrapper is a command line
  ${MAPDELTA_SERVER_WRAP:-} "$(server_bin)" serve --config "$dir/server.yaml" --port "$want" >"$dir/server.out" 2>>"$dir/server.log" &
  MD_SERVER_PID=$!
  MD_WRAP_PID=""
  if [ -n "${MAPDELTA_SERVER_WRAP:-}" ]; then
    MD_WRAP_PID=$MD_SERVER_PID
    MD_SERVER_PID=""
    for _ in $(seq 1 200); do
      MD_SERVER_PID=$(pgrep -P "$MD_WRAP_PID" -x mapdelta-server || true)
      [ -n "$MD_SERVER_PID" ] && break
      sleep 0.05
    done
    [ -n "$MD_SERVER_PID" ] || { echo "no server process under $MAPDELTA_SERVER_WRAP" >&2; return 1; }
  fi
  echo "$MD_SERVER_PID" >"$dir/server.pid"
  for _ in $(seq 1 200); do
    line=$(grep -m1 '^listening on ' "$dir/server.out" 2>/dev/null || true)
    [ -n "$line" ] && break
    kill -0 "$MD_SERVER_PID" 2>/dev/null || { echo "server exited at start; see $dir/server.log" >&2; return 1; }
    sleep 0.05
  done
  [ -n "$line" ] || { echo "server did not start within 10 s; see $dir/server.log" >&2; return 1; }
  MD_PORT=${line##*:}
}

# Stops the server with signal $1 (TERM or KILL) and returns its exit status.
md_server_stop() {
  local sig=${1:-TERM} status=0
  [ -n "${MD_SERVER_PID:-}" ] || return 0
  kill -s "$sig" "$MD_SERVER_PID" 2>/dev/null || true
  if [ -n "${MD_WRAP_PID:-}" ]; then  # the wrapper ends after its child, with its status
    { wait "$MD_WRAP_PID"; } 2>/dev/null || status=$?
    MD_WRAP_PID=""
  else
    { wait "$MD_SERVER_PID"; } 2>/dev/null || status=$?  # no "Killed" line per SIGKILL
  fi
  MD_SERVER_PID=""
  return $status
}

# The build's server and load driver, built under the shared build lock if missing.
md_ensure_built() {
  if [ ! -x "$(server_bin)" ] || [ ! -x "$build/bench/bench_load" ]; then
    flock /tmp/mapdelta-build.lock cmake --build "$build" --target mapdelta-server bench_load -j 2
  fi
}

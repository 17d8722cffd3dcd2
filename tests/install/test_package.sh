#!/usr/bin/env bash
# install.package: builds mapdelta's Debian package from the build folder, checks what it holds,
# extracts it into a temp root (dpkg -x, no root needed), starts the installed server from there
# on a free loopback port and fetches the web map and /health, then stops it with SIGTERM.
# usage: test_package.sh CPACK BUILD_DIR
set -euo pipefail
cpack=$1 build=$2
tmp=$(mktemp -d "${TMPDIR:-/tmp}/mapdelta_package_XXXXXX")
server_pid=""
cleanup() {
  if [ -n "$server_pid" ] && kill -0 "$server_pid" 2>/dev/null; then kill -KILL "$server_pid" 2>/dev/null || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# 1. The package.
start=$(date +%s)
(cd "$build" && "$cpack" -G DEB -B "$tmp/out" >"$tmp/cpack.log" 2>&1) || { cat "$tmp/cpack.log" >&2; fail "cpack -G DEB"; }
deb=$(ls "$tmp"/out/*.deb)
echo "built $(basename "$deb") ($(du -h "$deb" | cut -f1)) in $(( $(date +%s) - start )) s"
[ "$(dpkg-deb -f "$deb" Package)" = mapdelta ] || fail "package name"
depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
for lib in libsqlite3 libpcl-io libopencv-core liboctomap libcpp-httplib libyaml-cpp; do
  grep -q "$lib" <<<"$depends" || fail "Depends lacks $lib (dpkg-shlibdeps)"
done

# 2. Its files, where an installed system expects them.
root=$tmp/root
dpkg -x "$deb" "$root"
for f in usr/bin/mapdelta-server usr/bin/mapdelta-client usr/bin/mapdelta-sim usr/bin/mapdelta-eval \
         usr/bin/mapdelta-detect usr/share/mapdelta/web/index.html usr/share/mapdelta/config/server.example.yaml \
         usr/share/mapdelta/config/client.example.yaml usr/lib/systemd/system/mapdelta-server.service; do
  [ -e "$root/$f" ] || fail "$f not in the package"
done
ls "$root"/usr/share/mapdelta/migrations/001_*.sql >/dev/null || fail "migrations not in the package"
[ ! -e "$root/usr/share/mapdelta/web/.build-stamp" ] || fail "build stamp packaged"
unit=$root/usr/lib/systemd/system/mapdelta-server.service
grep -q '^ExecStart=/usr/bin/mapdelta-server serve --config /etc/mapdelta/server.yaml$' "$unit" ||
  fail "unit does not start /usr/bin/mapdelta-server: $(grep ExecStart "$unit")"
dpkg-deb --ctrl-tarfile "$deb" | tar -t | grep -q postinst || fail "no postinst (service user, /etc config)"

# 3. The unit's hardening, as systemd rates it (offline: no systemd needed).
if command -v systemd-analyze >/dev/null; then
  exposure=$(systemd-analyze security --offline=true "$unit" 2>/dev/null | sed -n 's/.*Overall exposure level for .*: \([0-9.]*\).*/\1/p')
  echo "systemd-analyze security: exposure $exposure"
  awk -v e="$exposure" 'BEGIN { exit !(e != "" && e < 3.0) }' || fail "unit exposure '$exposure' is not below 3"
fi

# 4. The installed programs run from the temp root (their libraries are the system's).
"$root/usr/bin/mapdelta-server" check-config --config "$root/usr/share/mapdelta/config/server.example.yaml" \
  >/dev/null || fail "the installed example config does not check"
"$root/usr/bin/mapdelta-client" --help >/dev/null || fail "mapdelta-client --help"
cat >"$tmp/server.yaml" <<YAML
http:
  port: 0
storage:
  database: $tmp/state/mapdelta.db
log:
  format: text
YAML
mkdir -p "$tmp/state"
"$root/usr/bin/mapdelta-server" serve --config "$tmp/server.yaml" >"$tmp/stdout.txt" 2>"$tmp/server.log" &
server_pid=$!
port=""
for _ in $(seq 1 100); do
  port=$(sed -n 's/^listening on .*:\([0-9]*\)$/\1/p' "$tmp/stdout.txt")
  [ -n "$port" ] && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$tmp/server.log" >&2; fail "the installed server exited"; }
  sleep 0.1
done
[ -n "$port" ] || { cat "$tmp/server.log" >&2; fail "no 'listening on' within 10 s"; }
curl -sf "http://127.0.0.1:$port/health" >"$tmp/health.json" || fail "GET /health"
grep -q '"status"' "$tmp/health.json" || fail "/health body: $(cat "$tmp/health.json")"
curl -sf "http://127.0.0.1:$port/" >"$tmp/index.html" || fail "GET / (web map)"
grep -q '<canvas id="view3d"' "$tmp/index.html" || fail "GET / is not the web map"
grep -q "web map served from $root/usr/share/mapdelta/web" "$tmp/server.log" ||
  fail "the installed server did not find its web map beside it: $(grep -i web "$tmp/server.log")"
kill -TERM "$server_pid"
status=0
wait "$server_pid" || status=$?
server_pid=""
[ "$status" -eq 0 ] || { cat "$tmp/server.log" >&2; fail "SIGTERM: exit $status"; }
echo "PASS: package installs, the installed server serves the web map and /health on port $port"

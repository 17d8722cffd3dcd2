#!/usr/bin/env bash
# Installs every build and run-time dependency of mapdelta from Debian 12's packages.
# Idempotent: packages already present are skipped, so it is cheap to call before each build.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config git
  libeigen3-dev libpcl-dev liboctomap-dev libceres-dev libopencv-dev
  libcpp-httplib-dev libsqlite3-dev sqlite3 libssl-dev zlib1g-dev nlohmann-json3-dev libyaml-cpp-dev libcli11-dev
  libnanoflann-dev libembree-dev libgtest-dev libgmock-dev libbenchmark-dev
  clang-format
  curl jq gnuplot-nox
)
# PostgreSQL backend (storage.backend: postgres): libpq to build, and the server binaries
# (initdb, postgres) that the tests start in a temp folder for each test process.
packages+=(libpq-dev postgresql)
# Web map (web/, tools/build-web.sh) and its browser test (tests/web): Debian's Chromium, and
# Node.js with npm unless a node with npm is already there (NodeSource's nodejs bundles npm and
# conflicts with Debian's npm package). Vite 7 needs Node >= 20.19.
packages+=(chromium)
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then packages+=(nodejs npm); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"

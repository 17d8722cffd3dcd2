#!/usr/bin/env bash
# Builds the web map (web/) into web/dist, which mapdelta-server serves at `/`.
# Idempotent: `npm ci` runs only when package-lock.json changed since the last install, and
# `npm run build` only when a source is newer than the last build. Network is needed only for
# the first `npm ci` (set-up time); the built page needs none at run time.
set -euo pipefail
web="$(cd "$(dirname "$0")/../web" && pwd)"
cd "$web"

need_node() {
  command -v node >/dev/null && command -v npm >/dev/null || {
    echo "build-web: node and npm are required (deploy/install-deps.sh installs them)" >&2; exit 1; }
  # Vite 7 needs Node >= 20.19 (or >= 22.12).
  node -e 'const [a,b]=process.versions.node.split(".").map(Number);
    process.exit(a>22||(a===22&&b>=12)||(a===20&&b>=19)?0:1)' || {
    echo "build-web: Node $(node --version) is too old for Vite 7 (need >= 20.19)" >&2; exit 1; }
}

newer_than() {  # newer_than STAMP FILES... : true if STAMP is missing or any file is newer
  local stamp=$1; shift
  [ -e "$stamp" ] || return 0
  [ -n "$(find "$@" -newer "$stamp" -print -quit 2>/dev/null)" ]
}

if newer_than node_modules/.package-lock.json package-lock.json package.json; then
  need_node
  echo "build-web: npm ci"
  if ! npm ci --no-audit --no-fund --loglevel=error 2>npm-ci.log; then
    # A registry mirror without other platforms' optional packages (rollup's @rollup/*
    # binaries) makes `npm ci` refuse the lock file as out of sync. `npm install --no-save`
    # installs the same pinned versions from package-lock.json without rewriting it.
    grep -q "Missing: @rollup/" npm-ci.log || { cat npm-ci.log >&2; exit 1; }
    echo "build-web: npm ci refused the lock (registry lacks other platforms' rollup binaries);" \
         "installing the locked versions with npm install --no-save"
    npm install --no-save --no-audit --no-fund --loglevel=error
  fi
  rm -f npm-ci.log
fi

if newer_than dist/.build-stamp index.html vite.config.js package-lock.json src; then
  need_node
  echo "build-web: vite build -> web/dist"
  npm run --silent build -- --logLevel warn
  touch dist/.build-stamp
else
  echo "build-web: web/dist is up to date"
fi

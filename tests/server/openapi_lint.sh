#!/usr/bin/env bash
# Lints server/openapi.yaml with Redocly CLI (npm @redocly/cli, pinned below) under the rules
# in server/redocly.yaml (recommended-strict plus our own: a schema for every body, 401/403
# on every protected operation, X-Request-Id on every response). Fails on any lint error.
# The CLI is installed from the npm registry into PREFIX at the first run (or when the pin
# changes); an unreachable registry is reported as such and fails the test.
# Usage: openapi_lint.sh SOURCE_DIR PREFIX
set -euo pipefail
src=$1
prefix=$2
version=2.77.0  # needs Node >= 20.19 (as the web build does)
cli="$prefix/node_modules/.bin/redocly"
export REDOCLY_TELEMETRY=off REDOCLY_SUPPRESS_UPDATE_NOTICE=true

if [ ! -x "$cli" ] || [ "$(cat "$prefix/.installed-version" 2>/dev/null)" != "$version" ]; then
  command -v npm >/dev/null || { echo "openapi-lint: npm not found (deploy/install-deps.sh installs it)" >&2; exit 1; }
  mkdir -p "$prefix"
  echo "openapi-lint: installing @redocly/cli@$version into $prefix"
  if ! npm install --prefix "$prefix" --no-audit --no-fund --loglevel=error "@redocly/cli@$version" \
      >"$prefix/npm-install.log" 2>&1; then
    echo "openapi-lint: could not install @redocly/cli@$version from the npm registry" \
         "$(npm config get registry 2>/dev/null) - is it reachable? npm said:" >&2
    tail -n 20 "$prefix/npm-install.log" >&2
    exit 1
  fi
  echo "$version" >"$prefix/.installed-version"
fi

"$cli" --version
"$cli" lint "$src/server/openapi.yaml" --config "$src/server/redocly.yaml" --format=stylish

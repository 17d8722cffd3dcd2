#!/usr/bin/env bash
# Runs tools/main-job.sh on already-built binaries and checks its summary.
set -euo pipefail
build_dir=$1
out=$2
here=$(cd "$(dirname "$0")" && pwd)
bash "$here/../../tools/main-job.sh" --no-build --build-dir "$build_dir" --out "$out" --seed 1 \
  --noise small
bash "$here/check_summary.sh" "$out/summary.json"

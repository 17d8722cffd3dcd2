#!/usr/bin/env bash
# Runs tools/main-job.sh on already-built binaries and checks its summary.
# Both changed scenes, one sequence each, as the main job's default.
set -euo pipefail
build_dir=$1
out=$2
here=$(cd "$(dirname "$0")" && pwd)
bash "$here/../../tools/main-job.sh" --no-build --build-dir "$build_dir" --out "$out" --seed 1 \
  --noise small --sequences S1_01,S2_01
bash "$here/check_summary.sh" "$out/summary.json"

#!/usr/bin/env bash
# Runs tools/main-job.sh on already-built binaries and checks its summary.
# The test drives S1_01 only: on S2_01 the VIO currently fails and resets 2.5 s before the end
# of the sequence, which wrecks the fused tail (see the open VIO issue); the main job itself
# still drives both sequences and prints their figures.
set -euo pipefail
build_dir=$1
out=$2
here=$(cd "$(dirname "$0")" && pwd)
bash "$here/../../tools/main-job.sh" --no-build --build-dir "$build_dir" --out "$out" --seed 1 \
  --noise small --sequences S1_01
bash "$here/check_summary.sh" "$out/summary.json"

#!/usr/bin/env bash
# usage: restore.sh RESULTS_JSON OUT_DIR
# Recreates the finished runs (OUT_DIR/runs/SEQ-NOISE-tK/run.json), the crowd result and the
# dataset times of a published reproduction (docs/results.json) in OUT_DIR, so that
# reproduce-paper.sh --out OUT_DIR resumes it on another machine: it skips every run that has a
# run.json and adds only the missing ones (e.g. more trials).
set -euo pipefail
[ $# -eq 2 ] || { sed -n '2,6p' "$0" >&2; exit 2; }
res=$1 out=$2
[ -f "$res" ] || { echo "restore: $res: missing" >&2; exit 1; }
jq -e '.runs | type == "array"' "$res" >/dev/null 2>&1 ||
  { echo "restore: $res: expected a reproduce-paper results.json (an object with a 'runs' array)" >&2; exit 1; }
mkdir -p "$out/runs"
n=0
while IFS=$'\t' read -r name i; do
  if [ -f "$out/runs/$name/run.json" ]; then
    echo "restore: $out/runs/$name/run.json exists, kept" >&2
    continue
  fi
  mkdir -p "$out/runs/$name"
  # Runs recorded before runs carried their machine ran on the record's machine.
  jq --argjson i "$i" '.machine as $m | .runs[$i] | if .machine == null and $m != null then .machine = ($m | {cpu, nproc}) else . end' "$res" \
    >"$out/runs/$name/run.json"
  n=$((n + 1))
done < <(jq -r '.runs | to_entries[] | "\(.value.sequence)-\(.value.noise)-t\(.value.trial)\t\(.key)"' "$res")
if jq -e '.crowd != null' "$res" >/dev/null && [ ! -f "$out/crowd/crowd.json" ]; then
  mkdir -p "$out/crowd"
  jq '.crowd' "$res" >"$out/crowd/crowd.json"
  echo "restore: crowd result restored" >&2
fi
[ -f "$out/dataset_times.jsonl" ] || jq -c '(.dataset_times // [])[]' "$res" >"$out/dataset_times.jsonl"
echo "restore: $n run(s) restored into $out/runs" >&2

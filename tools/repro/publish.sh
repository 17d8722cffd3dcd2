#!/usr/bin/env bash
# usage: publish.sh OUT_DIR NAME DOCS_DIR
# Copies a reproduction's plots to DOCS_DIR/images/results_NAME_<plot>.png and its results.json
# to DOCS_DIR/results_NAME.json (the record a later session resumes from: repro/restore.sh), and
# prints its report.md with headings one level down and image links pointing there, for
# docs/results.md.
set -euo pipefail
[ $# -eq 3 ] || { sed -n '2,6p' "$0" >&2; exit 2; }
out=$1 name=$2 docs=$3
[ -f "$out/report.md" ] || { echo "publish: $out/report.md: missing (run reproduce-paper.sh first)" >&2; exit 1; }
mkdir -p "$docs/images"
cp "$out/results.json" "$docs/results_${name}.json"
for p in "$out"/plots/*.png; do
  [ -e "$p" ] || continue
  cp "$p" "$docs/images/results_${name}_$(basename "$p")"
done
sed -e 's/^#/##/' -e "s#](plots/\([^)]*\))#](images/results_${name}_\1)#g" "$out/report.md"

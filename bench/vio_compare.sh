#!/usr/bin/env bash
# Two bench_vio binaries (e.g. one built from main, one from a branch) on the same sequence in
# one run, interleaved A B A B ... so both see the same machine load; prints each run's
# "current" row (front end and estimator ms per frame, thread CPU), the pipelined processing
# real-time factor, the tracking-quality row, then the medians side by side with their ratio
# and the load average before and after (bench/README.md). Ratio = baseline / new: above 1 a
# time fell (the new binary is faster) or a quality figure fell.
#   bash bench/vio_compare.sh BASELINE_BENCH_VIO NEW_BENCH_VIO SEQUENCE [ROUNDS] [SECONDS]
set -euo pipefail
if [ $# -lt 3 ]; then
  echo "usage: $0 BASELINE_BENCH_VIO NEW_BENCH_VIO SEQUENCE [ROUNDS=3] [SECONDS=1000]" >&2
  exit 2
fi
base=$1 new=$2 seq=$3 rounds=${4:-3} seconds=${5:-1000}
for bin in "$base" "$new"; do
  [ -x "$bin" ] || { echo "vio_compare: $bin is not an executable" >&2; exit 1; }
done
[ -d "$seq" ] || { echo "vio_compare: $seq is not a folder" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"
for r in $(seq 1 "$rounds"); do
  for side in base new; do
    bin=$base
    [ "$side" = new ] && bin=$new
    "$bin" --sequence "$seq" --seconds "$seconds" --no-baseline >"$work/$side.$r" 2>/dev/null
    # current row: name frames front_ms front_cpu est_ms est_cpu rt(cpu) rt(wall) pose_s ate resets
    awk -v s="$side" -v r="$r" '
      /^current/ && NF == 11 { t = $3 " " $4 " " $5 " " $6 " " $9 " " $10 " " $11 }
      /^current/ && NF == 6 { q = $2 " " $3 " " $4 " " $5 " " $6 }
      /real-time factor/ { rtf = $NF }
      END { print s, r, t, rtf, q }' "$work/$side.$r" >>"$work/rows"
  done
done
echo "load after:  $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-5s %5s %9s %9s %8s %8s %7s %7s %6s %6s %8s %7s %8s %7s %9s\n' side round front_ms \
  front_cpu est_ms est_cpu pose_s ate_m resets rtf features tracked track_len stereo landmarks
while read -r line; do printf '%-5s %5s %9s %9s %8s %8s %7s %7s %6s %6s %8s %7s %8s %7s %9s\n' $line; done <"$work/rows"
# Medians per side and the ratio baseline / new.
awk '
  function median(side, col,   n, i, j, t, v) {
    n = 0
    for (i = 1; i <= rows; ++i) if (s[i] == side) v[++n] = c[i, col]
    for (i = 1; i <= n; ++i) for (j = i + 1; j <= n; ++j) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
    return n % 2 ? v[(n + 1) / 2] : (v[n / 2] + v[n / 2 + 1]) / 2
  }
  { ++rows; s[rows] = $1; for (k = 3; k <= NF; ++k) c[rows, k] = $k }
  END {
    split("front_ms front_cpu est_ms est_cpu pose_s ate_m resets rtf features tracked track_len stereo landmarks", name, " ")
    printf "\nmedians        %10s %10s %8s\n", "baseline", "new", "base/new"
    for (k = 3; k <= 15; ++k) {
      b = median("base", k); n = median("new", k)
      printf "%-14s %10.3f %10.3f %8s\n", name[k - 2], b, n, n != 0 ? sprintf("%.2f", b / n) : "-"
    }
  }' "$work/rows"

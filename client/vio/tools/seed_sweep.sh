#!/usr/bin/env bash
# Seed sweep of the VIO on tiny simulated sequences: for every (seed, noise) generate the tiny
# dataset (S1_01, S2_01; no depth), run mapdelta-vio on both sequences, record ATE, resets and
# the ground truth's own attitude jumps (a reset there is the data's fault, not a divergence),
# delete the data, and print a table of ATE mean/max per noise and sequence.
#
#   client/vio/tools/seed_sweep.sh [--seeds "1 2 3"] [--noises "small big"] [--work DIR]
#                                  [--build DIR] [--keep] [--clean DIR --sequences "S2_02"]
#                                  [--seconds S]
# --clean DIR: instead of a tiny city per seed, noise seeds of one clean (--noise none) render,
# e.g. the paper preset's ~700 m sequences (`mapdelta-sim renoise`, ~90 s per sequence).
# --seconds S: with --clean, only the first S seconds of each sequence (a hard-linked copy of
# the clean render, renoised in S/170 of the time): start-up checks (20 s: 12 s per sequence).
# Output: DIR/runs.tsv (one row per run: ATE, resets, initializations refused by the bias-shift
# gate and the largest accepted shift in sigmas) and the summary on stdout. Runs niced, one at a time
# (~50 s CPU to generate a seed, ~20 s per VIO run); SWEEP_NICE=N sets the niceness (default 10),
# SWEEP_VIO_ARGS adds mapdelta-vio options (e.g. "--pipelined --set max_time=1").
set -euo pipefail

seeds="1 2 3 4 5 6 7 8 9 10"
noises="small big"
work=/work/data/vio-sweep
build=build
keep=0
clean=""
sequences="S1_01 S2_01"
seconds=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --seeds) seeds="$2"; shift 2 ;;
    --noises) noises="$2"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    --keep) keep=1; shift ;;
    --clean) clean="$2"; shift 2 ;;
    --sequences) sequences="$2"; shift 2 ;;
    --seconds) seconds="$2"; shift 2 ;;
    -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
    *) echo "seed_sweep.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
sim="$build/sim/mapdelta-sim"
vio="$build/client/vio/mapdelta-vio"
for bin in "$sim" "$vio"; do
  [[ -x "$bin" ]] || { echo "seed_sweep.sh: $bin not built (use --build DIR)" >&2; exit 2; }
done
mkdir -p "$work"
runs="$work/runs.tsv"
printf "noise\tseed\tsequence\tate_rmse\tate_max\tworst_segment_rmse\tresets\tgt_attitude_jumps\tvio_cpu_s\tinits_refused\tmax_accepted_shift\n" > "$runs"

# first_seconds CLEAN OUT S: the first S seconds of CLEAN's sequences (images hard-linked,
# CSVs cut, info.json's frames and duration updated), for renoise.
first_seconds() {
  local src=$1 dst=$2 secs=$3 sd seq d t0 tend cam n
  rm -rf "$dst"
  mkdir -p "$dst/sequences"
  ln -s "$(cd "$src/scenes" && pwd -P)" "$dst/scenes"
  for seq in $sequences; do
    sd=$(cd "$src/sequences/$seq" && pwd -P) d=$dst/sequences/$seq
    t0=$(sed -n 's/.*"t0_ns": *\([0-9]*\).*/\1/p' "$sd/info.json")
    tend=$((t0 + secs * 1000000000))
    # Times are 19 digits: compare as strings of equal length (awk's doubles lose the ns).
    cut_csv() { awk -F, -v te="$tend" 'NR == 1 || (length($1) == 19 && $1 <= te "")' "$1" > "$2"; }
    for cam in cam0 cam1; do
      mkdir -p "$d/mav0/$cam/data"
      cp "$sd/mav0/$cam/sensor.yaml" "$d/mav0/$cam/"
      cut_csv "$sd/mav0/$cam/data.csv" "$d/mav0/$cam/data.csv"
      tail -n +2 "$d/mav0/$cam/data.csv" | cut -d, -f2 | tr -d '\r ' |
        while read -r f; do ln "$sd/mav0/$cam/data/$f" "$d/mav0/$cam/data/$f"; done
    done
    mkdir -p "$d/mav0/imu0" "$d/mav0/state_groundtruth_estimate0"
    cp "$sd/mav0/imu0/sensor.yaml" "$d/mav0/imu0/"
    cut_csv "$sd/mav0/imu0/data.csv" "$d/mav0/imu0/data.csv"
    cut_csv "$sd/mav0/state_groundtruth_estimate0/data.csv" "$d/mav0/state_groundtruth_estimate0/data.csv"
    n=$(($(wc -l < "$d/mav0/cam0/data.csv") - 1))
    sed -e "s/\"frames\": *[0-9]*/\"frames\": $n/" -e "s/\"duration_s\": *[0-9.]*/\"duration_s\": $secs/" \
      "$sd/info.json" > "$d/info.json"
  done
}
if [[ -n "$seconds" ]]; then
  [[ -n "$clean" ]] || { echo "seed_sweep.sh: --seconds needs --clean" >&2; exit 2; }
  echo "== first $seconds s of $clean" >&2
  first_seconds "$clean" "$work/clean-first-${seconds}s" "$seconds"
  clean="$work/clean-first-${seconds}s"
fi

# Ground-truth attitude steps > ~5 deg between consecutive 200 Hz samples (physically impossible).
gt_jumps() {
  awk -F, 'NR > 2 { d = $5*w + $6*x + $7*y + $8*z; if (d < 0) d = -d; if (d < 0.999) n++ }
           NR > 1 { w = $5; x = $6; y = $7; z = $8 } END { print n + 0 }' "$1"
}

for noise in $noises; do
  for seed in $seeds; do
    data="$work/data-$noise-s$seed"
    rm -rf "$data"
    if [[ -n "$clean" ]]; then
      echo "== seed $seed, noise $noise: renoising $clean" >&2
      nice -n ${SWEEP_NICE:-10} "$sim" renoise --from "$clean" --out "$data" --noise "$noise" \
        --seed "$seed" --sequences "${sequences// /,}" --quiet > "$data.log" 2>&1
    else
      echo "== seed $seed, noise $noise: generating" >&2
      nice -n ${SWEEP_NICE:-10} "$sim" --preset tiny --out "$data" --seed "$seed" --noise "$noise" \
        --write_depth false --quiet > "$data.log" 2>&1
    fi
    for seq in $sequences; do
      dir="$data/sequences/$seq"
      log="$work/$seq-$noise-s$seed.log"
      out=$(nice -n ${SWEEP_NICE:-10} "$vio" --sequence "$dir" --out "$work/$seq-$noise-s$seed.tum" \
        ${SWEEP_VIO_ARGS:-} 2>"$log")
      refused=$(grep -c 'vio init rejected' "$log" || true)
      shift_max=$(sed -n 's/.*vio init accepted: the first solve moved the biases by \([0-9.e+-]*\) sigmas.*/\1/p' "$log" |
        sort -g | tail -1)
      ate=$(sed -n 's/^ATE (SE3-aligned.*rmse \([0-9.]*\) m .*max \([0-9.]*\)$/\1\t\2/p' <<< "$out")
      worst=$(sed -n 's/^segment .*rmse \([0-9.]*\) m.*/\1/p' <<< "$out" | sort -g | tail -1)
      resets=$(sed -n 's/.*resets \([0-9]*\)$/\1/p' <<< "$out")
      cpu=$(sed -n 's/^process CPU time \([0-9.]*\) s.*/\1/p' <<< "$out")
      jumps=$(gt_jumps "$dir/mav0/state_groundtruth_estimate0/data.csv")
      printf "%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n" "$noise" "$seed" "$seq" "$ate" "$worst" \
        "$resets" "$jumps" "$cpu" "$refused" "${shift_max:--}" | tee -a "$runs" >&2
      [[ $keep == 1 ]] || rm -f "$log"
    done
    [[ $keep == 1 ]] || rm -rf "$data" "$data.log"
  done
done

echo "ATE RMSE (SE3) over seeds: mean / max; resets (runs with a ground-truth attitude jump in brackets)"
awk -F'\t' 'NR > 1 {
    k = $1 " " $3; n[k]++; s[k] += $4; if ($4 > m[k]) m[k] = $4
    if ($6 > ws[k]) ws[k] = $6; r[k] += $7; if ($8 > 0) j[k]++ }
  END { for (k in n) printf "%-12s %5d %9.3f %9.3f %13.3f %7d %6d\n", k, n[k], s[k] / n[k], m[k], ws[k], r[k], j[k] }' "$runs" | sort |
  { printf "%-12s %5s %9s %9s %13s %7s %6s\n" "noise seq" runs mean max "worst segment" resets jumps; cat; }

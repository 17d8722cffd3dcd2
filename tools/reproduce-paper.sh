#!/usr/bin/env bash
# The paper's experiments (Lin et al., RA-L 2022, Sec. IV-V) on the simulator: Table III (ATE of
# VIO alone and prior-fused, averaged over trials), Fig. 4 (th_f sweep of R/P of both classes),
# Fig. 6 (change metrics from fused vs VIO-only poses), processing time per stage, and beyond the
# paper the crowdsourcing curve (R/P vs number of uploads aggregated by the server).
# Writes OUT/results.json, OUT/report.md and OUT/plots/*.png. Not part of CI: hours at full scope.
set -euo pipefail

usage() {
  cat <<'EOF2'
usage: bash tools/reproduce-paper.sh --out DIR [options]
  --out DIR           results folder (created; an interrupted run resumes: finished steps are kept)
  --preset NAME       mapdelta-sim preset: paper (default) or tiny
  --sequences LIST    comma-separated (default: S1_01,S1_02,S2_01,S2_02,S1_mirror,S1_dark for
                      paper, S1_01,S2_01 for tiny)
  --noise LIST        small,big (default)
  --trials N          noise seeds 1..N per sequence and noise (default 5; 0 = crowd only)
  --sweep-trials N    the th_f x bound sweep on trials 1..N only; later trials get the operating
                      point (default: every trial; 1 saves ~11 detector runs per later trial)
  --seed N            city seed of the clean render (default 1)
  --thf LIST          th_f sweep in metres (default 5,10,15,20,25,30)
  --bounds LIST       free-ray bounds in px for the sweep (default 128,0: 128 = the server's
                      default, 0 = the paper's rule); the first is the operating point
  --thf-point M       th_f of the operating point (Table, Fig. 6 analogue; default 20)
  --free-space RULE   mapdelta-detect's rule for the free space behind removed points: paper or
                      confident (default: mapdelta-detect's default; see its --help)
  --compare-free-space RULE
                      also detect at the operating point with RULE on the same keyframes (the
                      client does not depend on the rule): run.json's rule_compare
  --crowd LIST        numbers of uploads for the crowdsourcing curve (default 1,2,4,8; 'none' skips)
  --crowd-preset P    preset of the crowdsourcing scene (default tiny: 4 min; paper: about 40 min)
  --crowd-sequence S  sequence(s) the uploads drive, comma-separated, one scene (default S1_01;
                      S1_01,S1_02: upload i drives the i-th in turn), noise seed i, vehicle i
  --crowd-noise N     noise of the crowd uploads (default small)
  --crowd-replay DIR  upload the keyframes of an earlier crowd run (DIR = its --out) instead of
                      running the client again: the same N sessions through this build's server,
                      in minutes (for comparing server rules); reuses DIR's merged detections;
                      uploads past DIR's last one run the client fresh (e.g. 1,2,4,8 after 1,2,4)
  --data DIR          dataset cache (clean renders, renoised trials; default OUT/data)
  --dataset N:K=DIR   use DIR (a generated dataset) as noise N, trial K (repeatable), e.g.
                      small:1=/work/data/paper-small-s1
  --build-dir DIR     binaries (default build); mapdelta-sim needs 'renoise'
  --sim FILE          this mapdelta-sim instead of the build dir's
  --keep-data         keep renoised images and detector clouds (default: delete after use)
  --no-nice           run heavy steps at normal priority (default: nice -n 10)
  --report-only       only rebuild results.json, report.md and plots from OUT
  --redetect          finished runs whose detection another commit made keep their client
                      output (trajectories, keyframes, ATE) and get every detection again with
                      --build-dir's binaries: for a change of the detector alone. run.json then
                      holds the client's commit (commit) and the detector's (detect_commit)
  --help              this text
Every (sequence, noise, trial): the dataset (one clean render per sequence, then
'mapdelta-sim renoise' per seed), the client with --odometry vio (writes VIO-alone and fused
trajectories), ATE of both, mapdelta-detect + mapdelta-eval for every th_f x bound on the fused
keyframes, and once on the same keyframes with VIO-only poses. Progress goes to stderr, tool
output to OUT/log.txt.
EOF2
}

root=$(cd "$(dirname "$0")/.." && pwd)
out="" preset=paper sequences="" noises=small,big trials=5 city_seed=1 thf_list=5,10,15,20,25,30
bounds=128,0 thf_point=20 free_space="" compare_free_space="" crowd=1,2,4,8 crowd_preset=tiny crowd_seq=S1_01 crowd_noise=small crowd_replay=""
sweep_trials="" data="" build_dir=build sim_override="" keep_data=0 nice_cmd="nice -n 10" report_only=0 redetect=0
declare -A dataset_override=()
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out=$2; shift 2 ;;
    --preset) preset=$2; shift 2 ;;
    --sequences) sequences=$2; shift 2 ;;
    --noise) noises=$2; shift 2 ;;
    --trials) trials=$2; shift 2 ;;
    --sweep-trials) sweep_trials=$2; shift 2 ;;
    --seed) city_seed=$2; shift 2 ;;
    --thf) thf_list=$2; shift 2 ;;
    --bounds) bounds=$2; shift 2 ;;
    --thf-point) thf_point=$2; shift 2 ;;
    --free-space) free_space=$2; shift 2 ;;
    --compare-free-space) compare_free_space=$2; shift 2 ;;
    --crowd) crowd=$2; shift 2 ;;
    --crowd-preset) crowd_preset=$2; shift 2 ;;
    --crowd-sequence) crowd_seq=$2; shift 2 ;;
    --crowd-noise) crowd_noise=$2; shift 2 ;;
    --crowd-replay) crowd_replay=$(cd "$2" && pwd) || exit 2; shift 2 ;;
    --data) data=$2; shift 2 ;;
    --dataset)
      [[ "$2" =~ ^([a-z]+):([0-9]+)=(.+)$ ]] || { echo "reproduce-paper: --dataset '$2': expected NOISE:TRIAL=DIR" >&2; exit 2; }
      dataset_override["${BASH_REMATCH[1]}:${BASH_REMATCH[2]}"]=$(cd "${BASH_REMATCH[3]}" && pwd); shift 2 ;;
    --build-dir) build_dir=$2; shift 2 ;;
    --sim) sim_override=$2; shift 2 ;;
    --keep-data) keep_data=1; shift ;;
    --no-nice) nice_cmd=""; shift ;;
    --report-only) report_only=1; shift ;;
    --redetect) redetect=1; shift ;;
    --help|-h) usage; exit 0 ;;
    *) echo "reproduce-paper: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -n "$out" ] || { echo "reproduce-paper: --out is required (see --help)" >&2; exit 2; }
[[ "$trials" =~ ^[0-9]+$ ]] || { echo "reproduce-paper: --trials '$trials': expected an integer >= 0" >&2; exit 2; }
[ -n "$sweep_trials" ] || sweep_trials=$trials
[[ "$sweep_trials" =~ ^[0-9]+$ ]] || { echo "reproduce-paper: --sweep-trials '$sweep_trials': expected an integer >= 0" >&2; exit 2; }
[[ "$city_seed" =~ ^[0-9]+$ ]] || { echo "reproduce-paper: --seed '$city_seed': expected an integer" >&2; exit 2; }
for v in ${thf_list//,/ } $thf_point; do
  [[ "$v" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "reproduce-paper: th_f '$v' is not a number" >&2; exit 2; }
done
for v in ${bounds//,/ }; do [[ "$v" =~ ^[0-9]+$ ]] || { echo "reproduce-paper: bound '$v' is not an integer" >&2; exit 2; }; done
for v in ${noises//,/ } $crowd_noise; do
  case "$v" in none|small|big) ;; *) echo "reproduce-paper: noise '$v': expected none, small or big" >&2; exit 2 ;; esac
done
case "$free_space" in ""|paper|confident) ;; *) echo "reproduce-paper: --free-space '$free_space': expected paper or confident" >&2; exit 2 ;; esac
case "$compare_free_space" in ""|paper|confident) ;; *) echo "reproduce-paper: --compare-free-space '$compare_free_space': expected paper or confident" >&2; exit 2 ;; esac
case "$preset" in paper|tiny) ;; *) echo "reproduce-paper: --preset '$preset': expected paper or tiny" >&2; exit 2 ;; esac
if [ -z "$sequences" ]; then
  if [ "$preset" = paper ]; then sequences=S1_01,S1_02,S2_01,S2_02,S1_mirror,S1_dark; else sequences=S1_01,S2_01; fi
fi
if [ "$crowd" != none ]; then
  for v in ${crowd_seq//,/ }; do
    [ "${v%%_*}" = "${crowd_seq%%_*}" ] || { echo "reproduce-paper: --crowd-sequence '$crowd_seq': all of one scene" >&2; exit 2; }
  done
  for v in ${crowd//,/ }; do [[ "$v" =~ ^[1-9][0-9]*$ ]] || { echo "reproduce-paper: --crowd '$v' is not a positive integer" >&2; exit 2; }; done
fi
case "$build_dir" in /*) ;; *) build_dir=$root/$build_dir ;; esac
mkdir -p "$out"
out=$(cd "$out" && pwd)
[ -n "$data" ] || data=$out/data
mkdir -p "$data"
data=$(cd "$data" && pwd)
log=$out/log.txt
bin_sim=$build_dir/sim/mapdelta-sim bin_client=$build_dir/client/mapdelta-client
bin_server=$build_dir/server/mapdelta-server bin_eval=$build_dir/tools/mapdelta-eval
bin_detect=$build_dir/tools/mapdelta-detect
[ -z "$sim_override" ] || bin_sim=$(cd "$(dirname "$sim_override")" && pwd)/$(basename "$sim_override")
for b in "$bin_sim" "$bin_client" "$bin_server" "$bin_eval" "$bin_detect"; do
  [ -x "$b" ] || { echo "reproduce-paper: missing $b (build it, or pass --build-dir)" >&2; exit 1; }
done
command -v jq >/dev/null || { echo "reproduce-paper: jq is missing (deploy/install-deps.sh)" >&2; exit 1; }
command -v gnuplot >/dev/null || { echo "reproduce-paper: gnuplot is missing (deploy/install-deps.sh)" >&2; exit 1; }
"$bin_sim" renoise --help >/dev/null 2>&1 || { echo "reproduce-paper: $bin_sim has no 'renoise' (rebuild mapdelta-sim)" >&2; exit 1; }
started=$(date +%s)
# The commit of the binaries' source at the start ('-dirty' with uncommitted changes), recorded
# in every run: the tree --build-dir was configured from (a worktree at an older commit, say),
# else this checkout. Commits made while a reproduction runs do not change the binaries it uses.
bin_src=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build_dir/CMakeCache.txt" 2>/dev/null || true)
run_commit=$(git -C "${bin_src:-$root}" describe --always --dirty --abbrev=7 2>/dev/null || echo unknown)
# The machine, also recorded in every run: a reproduction resumed on another machine mixes CPUs,
# and the client's timings (and, through the VIO's solve-time cap, its estimates) depend on it.
run_cpu=$(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1)
operating_bound=${bounds%%,*}
vio_point="th_f $thf_point m, free-ray bound $operating_bound px"
# shellcheck source=repro/lib.sh
. "$root/tools/repro/lib.sh"
# shellcheck source=repro/crowd.sh
. "$root/tools/repro/crowd.sh"

jq -n --arg preset "$preset" --arg sequences "$sequences" --arg noises "$noises" --argjson trials "$trials" \
  --argjson sweep_trials "$sweep_trials" --arg free_space "$free_space" \
  --argjson seed "$city_seed" --arg thf "$thf_list" --arg bounds "$bounds" --argjson thf_point "$thf_point" \
  --arg crowd "$crowd" --arg crowd_preset "$crowd_preset" --arg crowd_seq "$crowd_seq" --arg crowd_noise "$crowd_noise" \
  --arg crowd_replay "$crowd_replay" --arg commit "$run_commit" \
  --arg started "$(date -u +%Y-%m-%dT%H:%M:%SZ)" --arg cpu "$run_cpu" \
  --argjson nproc "$(nproc)" --arg load "$(cut -d' ' -f1-3 /proc/loadavg)" \
  '{preset: $preset, sequences: ($sequences | split(",")), noises: ($noises | split(",")), trials: $trials,
    sweep_trials: $sweep_trials,
    city_seed: $seed, th_f_m: ($thf | split(",") | map(tonumber)), free_ray_bounds_px: ($bounds | split(",") | map(tonumber)),
    th_f_point_m: $thf_point, free_space: (if $free_space == "" then "default" else $free_space end), crowd: {uploads: $crowd, preset: $crowd_preset, sequence: $crowd_seq, noise: $crowd_noise, replay_of: (if $crowd_replay == "" then null else $crowd_replay end)},
    commit: $commit, started: $started, machine: {cpu: $cpu, nproc: $nproc, loadavg_at_start: $load}}' >"$out/params.json.new"
[ "$report_only" = 1 ] && [ -f "$out/params.json" ] || mv "$out/params.json.new" "$out/params.json"
rm -f "$out/params.json.new"

IFS=, read -r -a seq_list <<<"$sequences"
IFS=, read -r -a noise_list <<<"$noises"
IFS=, read -r -a thf_arr <<<"$thf_list"
IFS=, read -r -a bound_arr <<<"$bounds"
if [ "$report_only" = 0 ]; then
  total=$((${#seq_list[@]} * ${#noise_list[@]} * trials)) n=0
  for noise in "${noise_list[@]}"; do
    for k in $(seq 1 "$trials"); do  # empty for --trials 0
      for seq in "${seq_list[@]}"; do
        n=$((n + 1))
        run=$out/runs/$seq-$noise-t$k
        say "run $n/$total: $seq, noise $noise, trial $k"
        if [ -f "$run/run.json" ]; then
          if [ "$redetect" = 0 ] || [ "$(jq -r '.detect_commit // .commit' "$run/run.json")" = "$run_commit" ]; then
            say "  done earlier, kept"
            continue
          fi
          if ! client_done "$run"; then  # restored from a record: nothing to detect on
            say "  done earlier, no client output to detect again: kept"
            continue
          fi
          forget_detection "$run"
          say "  detection again with $run_commit (client output of $(cat "$run/client/commit") kept)"
        fi
        ds=$(ensure_dataset "$preset" "$noise" "$k" "$seq" "$(client_done "$run" && echo 0 || echo 1)")
        run_client "$ds" "$seq" "$run"
        evaluate_ate "$ds" "$seq" "$run"
        evaluate_pre_reset "$ds" "$seq" "$run"
        say "  ATE VIO $(jq -r '.rmse' "$run/ate_vio.json") m, fused $(jq -r '.rmse' "$run/ate_fused.json") m; change detection sweep"
        full_sweep=true sweep_bounds=("${bound_arr[@]}") sweep_thf=("${thf_arr[@]}")
        if [ "$k" -gt "$sweep_trials" ]; then
          full_sweep=false sweep_bounds=("$operating_bound") sweep_thf=("$thf_point")
        fi
        for b in "${sweep_bounds[@]}"; do
          for t in "${sweep_thf[@]}"; do
            detect_and_eval "$ds" "$seq" "$run/client/keyframes" "$run/detect/b$b-thf$t" "$t" "$b"
            say "  th_f $t m, bound $b px: $(jq -c '.paper | {R_new, P_new, R_rm, P_rm} | map_values(. * 1000 | round / 1000)' "$run/detect/b$b-thf$t/changes.json")"
          done
        done
        if [ -n "$compare_free_space" ]; then
          free_space=$compare_free_space detect_and_eval "$ds" "$seq" "$run/client/keyframes" \
            "$run/detect-rule-$compare_free_space" "$thf_point" "$operating_bound"
          say "  rule $compare_free_space on the same keyframes: $(jq -c '.paper | {R_new, P_new, R_rm, P_rm} | map_values(. * 1000 | round / 1000)' "$run/detect-rule-$compare_free_space/changes.json")"
        fi
        bash "$root/tools/repro/vio_keyframes.sh" "$run/client/keyframes" "$run/client/vio.txt" \
          "$ds/sequences/$seq/mav0/cam0/sensor.yaml" "$run/keyframes-vio"
        detect_and_eval "$ds" "$seq" "$run/keyframes-vio" "$run/detect-vio" "$thf_point" "$operating_bound"
        rm -rf "$run/keyframes-vio"
        say "  VIO-only poses: $(jq -c '.paper | {R_new, P_new, R_rm, P_rm} | map_values(. * 1000 | round / 1000)' "$run/detect-vio/changes.json")"
        run_json "$run" "$seq" "$noise" "$k" "$full_sweep" >"$run/run.json"
        prune_dataset "$ds" "$seq"
      done
    done
  done
  [ "$crowd" != none ] && crowd_experiment
fi

say "results.json, report.md and plots"
# The runs come on stdin and the rest as files: a dozen runs passed as one argument exceeded the
# kernel's 128 KiB limit. A missing part reads /dev/null, which --slurpfile makes [].
crowd_file=$out/crowd/crowd.json times_file=$out/dataset_times.jsonl
[ -f "$crowd_file" ] || crowd_file=/dev/null
[ -f "$times_file" ] || times_file=/dev/null
# A crowd-only run (--trials 0) has no runs/ folder: then no input, and jq -s makes [].
{ if [ -d "$out/runs" ]; then find "$out/runs" -name run.json | sort | xargs -r cat; fi; } |
  jq -s --slurpfile p "$out/params.json" --slurpfile crowd "$crowd_file" --slurpfile times "$times_file" \
    --arg finished "$(date -u +%Y-%m-%dT%H:%M:%SZ)" --arg load "$(cut -d' ' -f1-3 /proc/loadavg)" \
    '$p[0] + {finished: $finished, loadavg_at_end: $load, runs: ., crowd: ($crowd[0] // null), dataset_times: $times}' \
    >"$out/results.json"
bash "$root/tools/repro/report.sh" "$out/results.json" "$out"
say "done: $out/report.md, $out/results.json, $out/plots/"

# Functions of tools/reproduce-paper.sh (sourced; uses its variables: bin_*, data, out, preset,
# city_seed, nice_cmd, log, run_commit, run_cpu). Every step skips work whose output is already complete,
# so an interrupted reproduction resumes where it stopped.

say() { printf '==> [%s %4ds] %s\n' "$(date -u +%H:%M:%S)" $(($(date +%s) - started)) "$*" >&2; }
die() { echo "reproduce-paper: $*" >&2; exit 1; }

# Seconds since the epoch with ms, for stage timings.
now_s() { date +%s.%N | cut -c1-14; }
elapsed() { awk -v a="$1" -v b="$(now_s)" 'BEGIN { printf "%.2f", b - a }'; }

# ensure_dataset PRESET NOISE TRIAL SEQ [NEED_IMAGES] -> prints the dataset root holding
# sequences/SEQ. Trial k uses noise seed k on the clean render of city seed $city_seed; --dataset
# overrides. NEED_IMAGES 0 (the client has run): a pruned trial is enough, for its scenes, sensor
# files and ground truth.
ensure_dataset() {
  local p=$1 noise=$2 k=$3 seq=$4 need_images=${5:-1}
  local key="$noise:$k"
  if [ -n "${dataset_override[$key]:-}" ]; then
    [ -f "${dataset_override[$key]}/sequences/$seq/info.json" ] ||
      die "--dataset $key=${dataset_override[$key]}: no sequences/$seq/info.json"
    echo "${dataset_override[$key]}"
    return
  fi
  local clean=$data/clean-$p-s$city_seed root=$data/$p-$noise-s$city_seed-n$k
  # Pruned trials keep info.json but not their images: renoise again.
  if [ ! -f "$root/sequences/$seq/info.json" ] ||
    { [ "$need_images" = 1 ] && [ ! -d "$root/sequences/$seq/mav0/cam1/data" ]; }; then
    if [ ! -f "$clean/sequences/$seq/info.json" ]; then
      # Reproductions sharing --data (one per noise level, say) reach a sequence together: the
      # first renders it, the others wait on the lock and find it done. The lock goes with the
      # file descriptor when the subshell that prints the root exits, also on failure.
      local lock_fd
      exec {lock_fd}>"$data/.render-$p-s$city_seed.lock"
      flock "$lock_fd"
      if [ ! -f "$clean/sequences/$seq/info.json" ]; then
        say "render $p/$seq once without noise (city seed $city_seed) -> $clean"
        local t0; t0=$(now_s)
        $nice_cmd "$bin_sim" --preset "$p" --out "$clean" --noise none --seed "$city_seed" \
          --sequences "$seq" --quiet >>"$log" 2>&1 || die "mapdelta-sim failed (see $log)"
        echo "{\"preset\":\"$p\",\"sequence\":\"$seq\",\"render_s\":$(elapsed "$t0")}" >>"$out/dataset_times.jsonl"
      fi
      exec {lock_fd}>&-
    fi
    say "renoise $p/$seq: noise $noise, seed $k -> $root"
    local t0; t0=$(now_s)
    $nice_cmd "$bin_sim" renoise --from "$clean" --out "$root" --noise "$noise" --seed "$k" \
      --sequences "$seq" --quiet >>"$log" 2>&1 || die "mapdelta-sim renoise failed (see $log)"
    echo "{\"preset\":\"$p\",\"sequence\":\"$seq\",\"noise\":\"$noise\",\"seed\":$k,\"renoise_s\":$(elapsed "$t0")}" >>"$out/dataset_times.jsonl"
  fi
  echo "$root"
}

# Drops a renoised sequence's images after use (they are re-made in seconds); keeps --dataset overrides.
prune_dataset() {
  local root=$1 seq=$2
  [ "$keep_data" = 1 ] && return
  # A --dataset override is the caller's, even when it lies under --data with a trial's name.
  local dir
  for dir in "${dataset_override[@]}"; do [ "$root" = "$dir" ] && return; done
  case "$root" in "$data"/*-n[0-9]*) rm -rf "$root/sequences/$seq/mav0/cam0/data" "$root/sequences/$seq/mav0/cam1/data" ;; esac
}

# timing_json CLIENT_DIR -> JSON {stages: [{stage, seconds, calls, ms_per_call}], wall_s, frames, keyframes}
timing_json() {
  local wall frames kfs
  wall=$(awk '$1 == "wall" { print $2 }' "$1/timing.txt")
  frames=$(awk '$1 == "wall" { print $4 }' "$1/timing.txt" | tr -d ,)
  kfs=$(awk '$1 == "wall" { print $6 }' "$1/timing.txt" | tr -d ,)
  awk 'NR > 1 && $1 ~ /^[0-9]+$/ {
         name = $2; for (i = 3; i <= NF - 3; i++) name = name " " $i
         printf "{\"stage\":\"%s\",\"seconds\":%s,\"calls\":%s,\"ms_per_call\":%s}\n", name, $(NF-2), $(NF-1), $NF
       }' "$1/timing.txt" |
    jq -s --argjson wall "${wall:-null}" --argjson frames "${frames:-null}" --argjson kfs "${kfs:-null}" \
      '{stages: ., wall_s: $wall, frames: $frames, keyframes: $kfs}'
}

# client_done RUN_DIR: the client finished in RUN_DIR (its trajectories and keyframes are kept).
client_done() { [ -f "$1/client/timing.txt" ] && [ -f "$1/client/fused.txt" ]; }

# run_client DATASET SEQ RUN_DIR: the vehicle pipeline offline (prior from the dataset file).
run_client() {
  local ds=$1 seq=$2 run=$3
  client_done "$run" && return
  rm -rf "$run/client"
  mkdir -p "$run"
  say "client on $seq ($(basename "$run")): VIO + stereo depth + GICP to the prior + fusion"
  $nice_cmd "$bin_client" run --sequence "$ds/sequences/$seq" --odometry vio \
    --prior "$ds/scenes/original/cloud.pcd" --out "$run/client" >"$run/client.log" 2>&1 ||
    die "client failed on $seq (see $run/client.log)"
  echo "$run_commit" >"$run/client/commit"
}

# forget_detection RUN_DIR (--redetect): drops the run's record and detections, keeps the client
# output and notes the commit that made it (runs from before client/commit take run.json's).
forget_detection() {
  local run=$1
  [ -f "$run/client/commit" ] || jq -r '.commit // "unrecorded"' "$run/run.json" >"$run/client/commit"
  rm -rf "$run/run.json" "$run/detect" "$run/detect-vio" "$run"/detect-rule-*
}

# evaluate_ate DATASET SEQ RUN_DIR
evaluate_ate() {
  local ds=$1 seq=$2 run=$3
  local gt=$ds/sequences/$seq/mav0/state_groundtruth_estimate0/data.csv
  for which in vio fused; do
    "$bin_eval" ate "$gt" "$run/client/$which.txt" --json "$run/ate_$which.json" >/dev/null 2>>"$log" ||
      die "ATE of $run/client/$which.txt failed (see $log)"
  done
}

# evaluate_pre_reset DATASET SEQ RUN_DIR: VIO resets (client log) and, if any, the ATE of both
# trajectories up to the first reset (what the VIO delivered before it lost track).
evaluate_pre_reset() {
  local ds=$1 seq=$2 run=$3
  local gt=$ds/sequences/$seq/mav0/state_groundtruth_estimate0/data.csv
  local resets first
  resets=$(grep -c 'VIO reset at t_ns' "$run/client.log" || true)
  first=$(sed -n 's/.*VIO reset at t_ns \([0-9]*\).*/\1/p' "$run/client.log" | head -1)
  local vio=null fused=null
  if [ -n "$first" ]; then
    for which in vio fused; do
      awk -v t="$first" '/^#/ || $1 * 1e9 < t - 1e3' "$run/client/$which.txt" >"$run/${which}_pre_reset.txt"
      if [ "$(grep -vc '^#' "$run/${which}_pre_reset.txt")" -ge 3 ] &&
        "$bin_eval" ate "$gt" "$run/${which}_pre_reset.txt" --json "$run/ate_${which}_pre_reset.json" >/dev/null 2>>"$log"; then
        [ "$which" = vio ] && vio=$(jq -c '{rmse, std, max, pairs}' "$run/ate_vio_pre_reset.json")
        [ "$which" = fused ] && fused=$(jq -c '{rmse, std, max, pairs}' "$run/ate_fused_pre_reset.json")
      fi
    done
  fi
  jq -n --argjson n "$resets" --arg first "${first:-}" --argjson v "$vio" --argjson f "$fused" \
    '{vio_resets: $n, first_reset_s: (if $first == "" then null else (($first | tonumber) / 1e9 - 1.6e9) end),
      ate_vio_pre_reset: $v, ate_fused_pre_reset: $f}' >"$run/resets.json"
}

# detect_and_eval DATASET SEQ KEYFRAMES OUT_DIR TH_F BOUND: detection + paper metrics; the
# detector's wall time goes to OUT_DIR/time_s.
detect_and_eval() {
  local ds=$1 seq=$2 kf=$3 dir=$4 thf=$5 bound=$6
  [ -f "$dir/changes.json" ] && return
  local scene=${seq%%_*}
  local t0; t0=$(now_s)
  $nice_cmd "$bin_detect" --prior "$ds/scenes/original/cloud.pcd" --keyframes "$kf" --out "$dir" \
    --th-f "$thf" --free-ray-bound "$bound" ${free_space:+--free-space "$free_space"} >>"$log" 2>&1 ||
    die "mapdelta-detect failed on $kf (see $log)"
  elapsed "$t0" >"$dir/time_s"
  "$bin_eval" changes --original "$ds/scenes/original/cloud.pcd" --changed "$ds/scenes/$scene/cloud.pcd" \
    --new "$dir/new.pcd" --removed "$dir/removed.pcd" --global "$dir/global.pcd" \
    --observed "$dir/observed.bt" --json "$dir/changes.json" >/dev/null 2>>"$log" ||
    die "mapdelta-eval changes failed in $dir (see $log)"
  # The clouds are large and reproducible; the metrics and summary stay.
  [ "$keep_data" = 1 ] || rm -f "$dir/global.pcd" "$dir/observed.bt"
}

# run_json RUN_DIR SEQ NOISE TRIAL FULL_SWEEP(true|false) -> one run's JSON record (with the
# commit and machine that made it: a reproduction resumed in another session may mix both).
run_json() {
  local run=$1 seq=$2 noise=$3 k=$4
  local sweep="[]" d
  for d in "$run"/detect/b*-thf*; do
    [ -f "$d/changes.json" ] || continue
    local name; name=$(basename "$d")
    local b=${name#b}; b=${b%%-*}
    local t=${name##*thf}
    sweep=$(jq -c --argjson b "$b" --argjson t "$t" --slurpfile c "$d/changes.json" \
      --argjson s "$(cat "$d/time_s")" --slurpfile sum "$d/summary.json" '. + [{free_ray_bound_px: $b, th_f_m: $t, free_space: ($sum[0].free_space // "paper"), detect_s: $s, paper: $c[0].paper, reference_variant: $c[0].reference_variant}]' <<<"$sweep")
  done
  local vio="null" rule="null" d_rule
  [ -f "$run/detect-vio/changes.json" ] && vio=$(jq -c '{paper, reference_variant}' "$run/detect-vio/changes.json")
  # The operating point once more with another free-space rule (--compare-free-space).
  for d_rule in "$run"/detect-rule-*; do
    [ -f "$d_rule/changes.json" ] || continue
    rule=$(jq -c --slurpfile sum "$d_rule/summary.json" --argjson s "$(cat "$d_rule/time_s")" \
      '{free_space: ($sum[0].free_space // "paper"), detect_s: $s, paper, reference_variant}' "$d_rule/changes.json")
  done
  jq -n --arg seq "$seq" --arg noise "$noise" --argjson k "$k" --slurpfile resets "$run/resets.json" \
    --slurpfile av "$run/ate_vio.json" --slurpfile af "$run/ate_fused.json" \
    --argjson timing "$(timing_json "$run/client")" --argjson sweep "$sweep" --argjson vio "$vio" --argjson rule "$rule" \
    --arg vio_params "$vio_point" --argjson full_sweep "$5" \
    --arg commit "$(cat "$run/client/commit" 2>/dev/null || echo "$run_commit")" --arg detect_commit "$run_commit" \
    --arg cpu "$run_cpu" --argjson nproc "$(nproc)" \
    '{sequence: $seq, noise: $noise, trial: $k, commit: $commit, detect_commit: $detect_commit, machine: {cpu: $cpu, nproc: $nproc}, full_sweep: $full_sweep,
      ate_vio: ($av[0] | {rmse, std, max, mean, pairs}), ate_fused: ($af[0] | {rmse, std, max, mean, pairs}),
      client_timing: $timing, sweep: $sweep, rule_compare: $rule, vio_pose_changes: $vio, vio_pose_params: $vio_params} + $resets[0]'
}

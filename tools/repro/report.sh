#!/usr/bin/env bash
# usage: report.sh RESULTS_JSON OUT_DIR -> OUT_DIR/report.md and OUT_DIR/plots/*.png (gnuplot).
# Tables and plots of tools/reproduce-paper.sh's results.json (bash + jq + gnuplot only).
set -euo pipefail
[ $# -eq 2 ] || { sed -n '2,3p' "$0" >&2; exit 2; }
res=$1 out=$2
[ -f "$res" ] || { echo "report: $res: missing" >&2; exit 1; }
plots=$out/plots
mkdir -p "$plots"
md=$out/report.md
f3() { awk -v x="$1" 'BEGIN { if (x == "" || x == "null" || x == "nan") print "–"; else printf "%.3f", x }'; }

# jq on the results.
J() { jq -r "$@" "$res"; }

# paper_rmse SEQUENCE NOISE COLUMN -> the paper's Table III value (column 3: PPCA-VINS RMSE,
# 6: VINS-Fusion RMSE) or "null" where the paper has no row.
paper_table=$(dirname "$0")/paper_table3.tsv
paper_rmse() {
  awk -F'\t' -v s="$1" -v n="$2" -v c="$3" '!/^#/ && $1 == s && $2 == n { v = $(c) } END { print (v == "" ? "null" : v) }' "$paper_table"
}

{
  echo "# mapdelta: the paper's experiments on the simulator"
  echo
  J '"Preset `\(.preset)`, sequences \(.sequences | join(", ")), noise \(.noises | join(", ")), \(.trials) trial(s) (noise seeds 1..\(.trials)), city seed \(.city_seed). Commit `\(.commit)`, started \(.started), finished \(.finished); machine: \(.machine.nproc) × \(.machine.cpu), load average \(.machine.loadavg_at_start) at start, \(.loadavg_at_end) at the end."'
  # A run resumed over several sessions may hold runs made by different commits, and a run
  # detected again (--redetect) has the detector's besides the client's: say which.
  J '[.runs[] | (.commit // "unrecorded") as $c | if (.detect_commit // $c) != $c then "\($c), detection \(.detect_commit)" else $c end]
     | group_by(.) | if length > 1 or any(.[]; .[0] | contains(", detection")) then
       "\nRuns by commit: " + (map("`\(.[0])` (\(length))") | join(", ")) + "." else empty end'
  J '[.runs[] | .machine.cpu // "unrecorded"] | group_by(.) | if length > 1 then
       "\nRuns by machine: " + (map("\(.[0]) (\(length))") | join(", ")) + ". The client'"'"'s timings differ between them (see Processing time)." else empty end'
  J 'if .trials > 0 and .sweep_trials == 0 then
       "\nNo th_f sweep in this record (`--sweep-trials 0`): every trial has the operating point only (Table III, Fig. 6)."
     elif (.sweep_trials // .trials) < .trials then
       "\nThe th_f sweep (Fig. 4 analogue, per-sequence table) covers trials 1..\(.sweep_trials); every trial has the operating point (Table III, Fig. 6)." else empty end'
  echo
  echo "## Table III analogue: ATE (m, SE(3)-aligned, keyframe poses), mean over trials"
  echo
  echo "Beside ours, the paper's own Table III (its AirSim sequences of the same names, 5 runs): RMSE of"
  echo "PPCA-VINS (its prior-assisted VIO, our *fused*) and of VINS-Fusion (VIO alone, our *VIO*)."
  echo
  echo "| sequence | noise | trials | VIO RMSE | VIO STD | VIO MAX | fused RMSE | fused STD | fused MAX | paper PPCA-VINS RMSE | paper VINS-Fusion RMSE |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
  J '.runs | group_by([.sequence, .noise]) | .[] |
     def m(f): (map(f) | add / length);
     [.[0].sequence, .[0].noise, length, m(.ate_vio.rmse), m(.ate_vio.std), m(.ate_vio.max),
      m(.ate_fused.rmse), m(.ate_fused.std), m(.ate_fused.max)] | map(. // "nan") | @tsv' |
    while IFS=$'\t' read -r s n k a b c d e f; do
      echo "| $s | $n | $k | $(f3 "$a") | $(f3 "$b") | $(f3 "$c") | $(f3 "$d") | $(f3 "$e") | $(f3 "$f") | $(f3 "$(paper_rmse "$s" "$n" 3)") | $(f3 "$(paper_rmse "$s" "$n" 6)") |"
    done
  if J '.runs | any((.vio_resets // 0) > 0)' | grep -q true; then
    echo
    echo "The VIO lost track and reset in some runs; the ATE above then spans segments the client had to re-anchor. Up to the first reset:"
    echo
    echo "| sequence | noise | trial | VIO resets | first reset (s) | VIO RMSE before | fused RMSE before | keyframes before |"
    echo "|---|---|---|---|---|---|---|---|"
    J '.runs | sort_by(.sequence, .noise, .trial) | .[] | [.sequence, .noise, .trial, (.vio_resets // 0), (.first_reset_s // "–"),
        (.ate_vio_pre_reset.rmse // "null"), (.ate_fused_pre_reset.rmse // "null"), (.ate_vio_pre_reset.pairs // "–")] | @tsv' |
      while IFS=$'\t' read -r s n k r t a b p; do
        echo "| $s | $n | $k | $r | $t | $(f3 "$a") | $(f3 "$b") | $p |"
      done
  fi
  if J '.runs | any(.trial > 1)' | grep -q true; then
    echo
    echo "Per trial (RMSE VIO → fused):"
    echo
    J '.runs | sort_by(.sequence, .noise, .trial) | .[] | "- \(.sequence) \(.noise) trial \(.trial): \(.ate_vio.rmse * 1000 | round / 1000) → \(.ate_fused.rmse * 1000 | round / 1000) m"'
  fi
  echo
  echo "## Fig. 4 analogue: th_f sweep (fused poses), mean over sequences and trials"
  echo
  echo "The paper's Fig. 4 uses small noise; big noise is shown beside it (dashed in the plots)."
  echo
  # Noise levels and bounds present in the swept runs (a resumed reproduction may have swept more
  # than its last call asked for).
  sweep_noises=$(J '[.runs[] | select(.full_sweep != false) | .noise] | unique | sort_by(if . == "small" then 0 elif . == "big" then 1 else 2 end) | join(" ")')
  # A record without swept runs (--sweep-trials 0, or crowd only) says so instead of empty tables.
  [ -n "$sweep_noises" ] || { echo "No run in this record swept th_f."; echo; }
  for b in $(J '.free_ray_bounds_px as $p | ($p + ([.runs[].sweep[].free_ray_bound_px] | unique | map(select(. as $x | $p | index($x) | not))))[]'); do
    if [ "$b" = 0 ]; then bound_text="Free-ray bound 0 (the paper's rule: every pixel without depth is free space up to th_f)"
    else bound_text="Free-ray bound $b px (the server's default: a pixel without depth is free only up to the nearest depth within $b px)"; fi
    plot_cmd=""
    for noise in $sweep_noises; do
      echo "$bound_text, $noise noise:"
      echo
      echo "| th_f (m) | R_new | P_new | R_rm | P_rm | detect time (s) | runs |"
      echo "|---|---|---|---|---|---|---|"
      # Only runs that swept every th_f (see --sweep-trials): each row then averages the same runs.
      J --argjson b "$b" --arg noise "$noise" '[.runs[] | select(.full_sweep != false and .noise == $noise) | .sweep[] | select(.free_ray_bound_px == $b)] | group_by(.th_f_m) | .[] |
         def m(f): (map(f) | map(select(. != null)) | if length == 0 then null else add / length end);
         [.[0].th_f_m, m(.paper.R_new), m(.paper.P_new), m(.paper.R_rm), m(.paper.P_rm), m(.detect_s), length] | map(. // "nan") | @tsv' |
        tee "$plots/thf_b$b-$noise.dat" |
        while IFS=$'\t' read -r t a bb c d e k; do
          echo "| $t | $(f3 "$a") | $(f3 "$bb") | $(f3 "$c") | $(f3 "$d") | $(awk -v x="$e" 'BEGIN{printf "%.1f", x}') | $k |"
        done
      echo
      if [ -s "$plots/thf_b$b-$noise.dat" ]; then
        style="lw 1 dt 2"  # small noise solid and bold, other levels dashed
        [ "$noise" = small ] && style="lw 2 dt 1"
        for spec in "2 7 R_{new}" "3 5 P_{new}" "4 9 R_{rm}" "5 11 P_{rm}"; do
          read -r col point label <<<"$spec"
          plot_cmd+="${plot_cmd:+, }\"$plots/thf_b$b-$noise.dat\" u 1:$col w lp $style pt $point lc $((col - 1)) t \"$label $noise\""
        done
      fi
    done
    # A crowd-only reproduction (--trials 0) has no sweep points to plot.
    if [ -n "$plot_cmd" ]; then
      echo "![th_f sweep, bound $b px](plots/thf_b$b.png)"
      echo
      gnuplot <<EOG
set terminal pngcairo size 720,460 font "sans,10"
set output "$plots/thf_b$b.png"
set title "th_f sweep (free-ray bound $b px), mean over runs (solid: small noise, dashed: big)"
set xlabel "th_f (m)"; set ylabel "recall / precision"; set yrange [0:1.05]; set grid; set key bottom left
plot $plot_cmd
EOG
    fi
  done
  if [ -n "$sweep_noises" ]; then
    echo "Per sequence (mean over trials):"
    echo
    echo "| sequence | noise | bound (px) | th_f (m) | R_new | P_new | R_rm | P_rm |"
    echo "|---|---|---|---|---|---|---|---|"
    J '[.runs[] | select(.full_sweep != false) | . as $r | .sweep[] | . + {sequence: $r.sequence, noise: $r.noise}] |
       group_by([.sequence, .noise, .free_ray_bound_px, .th_f_m]) | .[] |
       def m(f): (map(f) | map(select(. != null)) | if length == 0 then null else add / length end);
       [.[0].sequence, .[0].noise, .[0].free_ray_bound_px, .[0].th_f_m, m(.paper.R_new), m(.paper.P_new), m(.paper.R_rm), m(.paper.P_rm)] | map(. // "nan") | @tsv' |
      while IFS=$'\t' read -r s n b t a bb c d; do
        echo "| $s | $n | $b | $t | $(f3 "$a") | $(f3 "$bb") | $(f3 "$c") | $(f3 "$d") |"
      done
    echo
  fi
  echo "## Fig. 6 analogue: change metrics from fused vs VIO-only poses ($(J '.runs[0].vio_pose_params // "?"'))"
  echo
  echo "| sequence | noise | poses | R_new | P_new | R_rm | P_rm |"
  echo "|---|---|---|---|---|---|---|"
  : >"$plots/fig6.dat"
  J '.th_f_point_m as $t | (.free_ray_bounds_px[0]) as $b | .runs | group_by([.sequence, .noise]) | .[] |
     def m(f): (map(f) | map(select(. != null)) | if length == 0 then null else add / length end);
     (map(.sweep[] | select(.th_f_m == $t and .free_ray_bound_px == $b))) as $fz |
     [.[0].sequence, .[0].noise,
      ($fz | m(.paper.R_new)), ($fz | m(.paper.P_new)), ($fz | m(.paper.R_rm)), ($fz | m(.paper.P_rm)),
      m(.vio_pose_changes.paper.R_new), m(.vio_pose_changes.paper.P_new), m(.vio_pose_changes.paper.R_rm), m(.vio_pose_changes.paper.P_rm)] | map(. // "nan") | @tsv' |
    while IFS=$'\t' read -r s n a b c d e f g h; do
      echo "| $s | $n | fused | $(f3 "$a") | $(f3 "$b") | $(f3 "$c") | $(f3 "$d") |"
      echo "| $s | $n | VIO only | $(f3 "$e") | $(f3 "$f") | $(f3 "$g") | $(f3 "$h") |"
      for m in "R_new $a $e" "P_new $b $f" "R_rm $c $g" "P_rm $d $h"; do
        set -- $m
        echo "\"$s $1\" $2 $3" >>"$plots/fig6.dat"
      done
    done
  echo
  echo "![fused vs VIO-only poses](plots/fig6.png)"
  [ -s "$plots/fig6.dat" ] && gnuplot <<EOG
set terminal pngcairo size 900,420 font "sans,10" noenhanced
set output "$plots/fig6.png"
set title "Change metrics from fused vs VIO-only poses"
set style data histogram; set style histogram clustered gap 1; set style fill solid 0.8 border -1
set yrange [0:1.05]; set grid y; set xtics rotate by -35 nomirror; set key top right
plot "$plots/fig6.dat" u 2:xtic(1) t "fused", "" u 3 t "VIO only"
EOG
  echo
  echo "## Processing time per stage"
  echo
  echo "Vehicle client (\`timing.txt\`), mean over the runs above:"
  echo
  echo "| stage | ms per call | calls per run | s per run |"
  echo "|---|---|---|---|"
  J '[.runs[].client_timing.stages[]] | group_by(.stage) | .[] |
     [.[0].stage, (map(.ms_per_call) | add / length), (map(.calls) | add / length), (map(.seconds) | add / length)] | @tsv' |
    while IFS=$'\t' read -r s a b c; do
      printf '| %s | %.1f | %.0f | %.1f |\n' "$s" "$a" "$b" "$c"
    done
  J '.runs | if length > 0 then "\nClient wall time per run: \(map(.client_timing.wall_s) | add / length | . * 10 | round / 10) s for \(map(.client_timing.frames) | add / length | round) frames, \(map(.client_timing.keyframes) | add / length | round) keyframes (mean); offline change detection (mapdelta-detect) \(map(.sweep[].detect_s) | add / length | . * 10 | round / 10) s per call." else empty end'
  J '.runs | group_by(.machine.cpu // "unrecorded") | if length > 1 then
       "\nBy machine: " + (map("\(.[0].machine.cpu // "unrecorded"): client \(map(.client_timing.wall_s) | add / length | . * 10 | round / 10) s per run, mapdelta-detect \(map(.sweep[].detect_s) | add / length | . * 10 | round / 10) s per call (\(length) runs)") | join("; ")) + "."
     else empty end'
  J 'if (.crowd // null) != null then "\nServer commit jobs (crowd experiment, \(.crowd.preset) \(.crowd.sequence)): " +
       ([.crowd.commit_jobs[] | select(.started_at != null and .finished_at != null) |
         ((.finished_at | sub("\\.[0-9]+"; "") | fromdateiso8601) - (.started_at | sub("\\.[0-9]+"; "") | fromdateiso8601))] |
        if length > 0 then "\(length) jobs, \(add / length | . * 10 | round / 10) s mean, \(max) s max (1 s resolution)." else "no finished jobs." end)
     else empty end'
  # Per sequence: a resumed reproduction renders again on every new machine and renoises per trial.
  J 'def s(f): map(f) | "\(add / length | round) s" + (if length > 1 then " (mean of \(length))" else "" end);
     if (.dataset_times | length) > 0 then "\nDatasets made by this run (wall time): " +
       (.dataset_times | group_by([.preset, .sequence]) | map(
          (map(select(.render_s)) as $r | map(select(.renoise_s)) as $n |
           "\(.[0].preset)/\(.[0].sequence) " + ([if ($r | length) > 0 then "render \($r | s(.render_s))" else empty end,
                                                 if ($n | length) > 0 then "renoise \($n | s(.renoise_s))" else empty end] | join(", ")))) | join("; ")) + "."
     else empty end'
  if J '.crowd != null' | grep -q true; then
    echo
    echo "## Crowdsourcing: recall and precision vs number of uploads (beyond the paper)"
    echo
    J '"The same changed scene (\(.crowd.preset) \(.crowd.sequence)) driven N times with noise seeds 1..N, every session uploaded to one server and committed; the server aggregates sessions per tile and classifies against the merged observed area. **all**: every change point the server reports; **majority**: points with confidence > 0.5 (more supporting than non-supporting sessions). **offline merged**: mapdelta-detect on the N sessions'"'"' keyframes together (also the P_g / A_obs of the evaluation)."'
    echo
    echo "| uploads | all R_new | all P_new | all R_rm | all P_rm | majority R_new | majority P_new | majority R_rm | majority P_rm | offline R_new | offline P_new | offline R_rm | offline P_rm | changed tiles |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    J '.crowd.snapshots[] | [.uploads, .server_all.R_new, .server_all.P_new, .server_all.R_rm, .server_all.P_rm,
        .server_majority.R_new, .server_majority.P_new, .server_majority.R_rm, .server_majority.P_rm,
        .offline_merged.R_new, .offline_merged.P_new, .offline_merged.R_rm, .offline_merged.P_rm, (.changed_tiles | length)] | @tsv' |
      tee "$plots/crowd.dat" |
      while IFS=$'\t' read -r n a b c d e f g h i j k l t; do
        echo "| $n | $(f3 "$a") | $(f3 "$b") | $(f3 "$c") | $(f3 "$d") | $(f3 "$e") | $(f3 "$f") | $(f3 "$g") | $(f3 "$h") | $(f3 "$i") | $(f3 "$j") | $(f3 "$k") | $(f3 "$l") | $t |"
      done
    echo
    echo "![crowdsourcing curve](plots/crowd.png)"
    gnuplot <<EOG
set terminal pngcairo size 720,440 font "sans,10"
set output "$plots/crowd.png"
set title "Server aggregation: metrics vs number of uploads (solid: all points, dashed: confidence > 0.5)"
set logscale x 2; set xlabel "uploads"; set ylabel "recall / precision"; set yrange [0:1.05]; set grid; set key bottom right
plot "$plots/crowd.dat" u 1:2 w lp lw 2 pt 7 lc 1 t "R_{new}", "" u 1:3 w lp lw 2 pt 5 lc 2 t "P_{new}", \
     "" u 1:4 w lp lw 2 pt 9 lc 3 t "R_{rm}", "" u 1:5 w lp lw 2 pt 11 lc 4 t "P_{rm}", \
     "" u 1:6 w lp lw 1 dt 2 pt 7 lc 1 notitle, "" u 1:7 w lp lw 1 dt 2 pt 5 lc 2 notitle, \
     "" u 1:8 w lp lw 1 dt 2 pt 9 lc 3 notitle, "" u 1:9 w lp lw 1 dt 2 pt 11 lc 4 notitle
EOG
    if J '[.crowd.snapshots[] | .server_confirmed] | all(. != null)' | grep -q true; then
      echo
      echo "### Change lifecycle: every reported point vs the points of confirmed clusters"
      echo
      echo "Upload i comes from its own vehicle. A change cluster (connected changed voxels of one kind in a tile) is confirmed when lifecycle.confirm_sessions supporting sessions from lifecycle.confirm_vehicles vehicles back it (server defaults: 2 and 2; evidence weighted by localization quality). **all** = every point the server reports (candidate or confirmed clusters); **confirmed** = \`GET /v1/changes/tiles/{t}?state=confirmed,applied\`. A metric is – where there is no point to measure."
      echo
      echo "| uploads | clusters candidate / confirmed (new) | clusters candidate / confirmed (removed) | all R_new | all P_new | all R_rm | all P_rm | confirmed R_new | confirmed P_new | confirmed R_rm | confirmed P_rm |"
      echo "|---|---|---|---|---|---|---|---|---|---|---|"
      J '.crowd.snapshots[] | (.clusters // []) as $c |
          def n(k; s): ([$c[] | select(.kind == k and .state == s) | .clusters] | add // 0);
          [.uploads, "\(n("new"; "candidate")) / \(n("new"; "confirmed"))", "\(n("removed"; "candidate")) / \(n("removed"; "confirmed"))",
           .server_all.R_new, .server_all.P_new, .server_all.R_rm, .server_all.P_rm,
           .server_confirmed.R_new, .server_confirmed.P_new, .server_confirmed.R_rm, .server_confirmed.P_rm] | map(. // "nan") | @tsv' |
        tee "$plots/crowd_lifecycle.dat" |
        while IFS=$'\t' read -r n cn cr a b c d e f g h; do
          echo "| $n | $cn | $cr | $(f3 "$a") | $(f3 "$b") | $(f3 "$c") | $(f3 "$d") | $(f3 "$e") | $(f3 "$f") | $(f3 "$g") | $(f3 "$h") |"
        done
      echo
      echo "![lifecycle curve](plots/crowd_lifecycle.png)"
      gnuplot <<EOG
set terminal pngcairo size 720,440 font "sans,10"
set output "$plots/crowd_lifecycle.png"
set title "Precision of every reported point (dashed) and of confirmed clusters (solid) vs uploads"
set logscale x 2; set xlabel "uploads"; set ylabel "precision / recall"; set yrange [0:1.05]; set grid; set key bottom right
set datafile missing "nan"
# Tab-separated: the cluster columns ("33 / 0") hold spaces, which split them by default.
set datafile separator "\t"
plot "$plots/crowd_lifecycle.dat" u 1:9 w lp lw 2 pt 5 lc 2 t "confirmed P_{new}", "" u 1:11 w lp lw 2 pt 11 lc 4 t "confirmed P_{rm}", \
     "" u 1:8 w lp lw 1 pt 7 lc 1 t "confirmed R_{new}", "" u 1:10 w lp lw 1 pt 9 lc 3 t "confirmed R_{rm}", \
     "" u 1:5 w lp lw 1 dt 2 pt 5 lc 2 t "all P_{new}", "" u 1:7 w lp lw 1 dt 2 pt 11 lc 4 t "all P_{rm}"
EOG
    fi
  fi
  echo
  echo "Machine-readable: \`results.json\` (every run, every sweep point, the crowd snapshots, timings)."
} >"$md"
echo "report: $md" >&2

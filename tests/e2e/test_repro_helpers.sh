#!/usr/bin/env bash
# Checks the paper-reproduction helpers against hand-computed answers (no simulator run):
#  - repro/vio_keyframes.sh: T_map_cam = T_map_body * T_BS for an identity pose and a 90 deg yaw;
#    a keyframe without a VIO pose is an error.
#  - repro/crowd.sh merge_keyframes: stamps of session i shifted by i*1000 s, depth renamed.
#  - repro/report.sh: Table III means over trials beside the paper's values, the th_f table per
#    noise level and the PNGs.
#  - repro/report.sh: runs and timings by machine, dataset times per sequence.
#  - repro/restore.sh: the runs of a results.json come back as OUT/runs/SEQ-NOISE-tK/run.json,
#    each with its machine.
#  - --redetect's helpers: forget_detection keeps the client output and its commit; a pruned
#    trial serves a finished client without renoising; report.sh and compare.sh name both commits.
#  - repro/report.sh of a record without a th_f sweep (--sweep-trials 0) says so.
#  - ensure_dataset: two reproductions sharing --data render a sequence once.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
tools=$here/../../tools
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# A keyframe folder with two keyframes and T_BS = the simulator's body->cam0 (x right = -y_body...).
kf=$tmp/kf
mkdir -p "$kf/depth"
printf 'width: 4\nheight: 2\nfx: 2\nfy: 2\ncx: 2\ncy: 1\ndepth_scale: 1000\n' >"$kf/camera.yaml"
printf '# t x y z qx qy qz qw  (T_map_cam)\n1.000000000 0 0 0 0 0 0 1\n2.000000000 0 0 0 0 0 0 1\n' >"$kf/poses.txt"
: >"$kf/depth/1000000000.png"
: >"$kf/depth/2000000000.png"
printf 'T_BS:\n  cols: 4\n  rows: 4\n  data: [0, 0, 1, 0.1, -1, 0, 0, 0.5, 0, -1, 0, 0.05, 0, 0, 0, 1]\n' >"$tmp/cam0.yaml"
# Keyframe 1: identity body pose at (1, 2, 3); keyframe 2: yaw +90 deg at the origin.
s=$(awk 'BEGIN { printf "%.12f", sqrt(0.5) }')
printf '# t x y z qx qy qz qw\n1.000000000 1 2 3 0 0 0 1\n2.000000000 0 0 0 0 0 %s %s\n' "$s" "$s" >"$tmp/vio.txt"
bash "$tools/repro/vio_keyframes.sh" "$kf" "$tmp/vio.txt" "$tmp/cam0.yaml" "$tmp/kfv"
# Expected: kf1 t = (1.1, 2.5, 3.05), q of R_bc = [0 0 1; -1 0 0; 0 -1 0] = +-(-0.5, 0.5, -0.5, 0.5).
# kf2: R = Rz(90) * R_bc = [1 0 0; 0 0 1; 0 -1 0] (rotation of -90 deg about x): q = +-(-0.7071, 0, 0, 0.7071),
#      t = Rz(90) * (0.1, 0.5, 0.05) = (-0.5, 0.1, 0.05).
check_pose() {  # LINE expected-t(3) expected-q(4)
  awk -v l="$1" -v e="$2 $3 $4 $5 $6 $7 $8" 'BEGIN { split(l, a, " "); split(e, b, " ")
    sgn = (a[5]*b[4] + a[6]*b[5] + a[7]*b[6] + a[8]*b[7] < 0) ? -1 : 1
    for (i = 1; i <= 3; i++) if ((a[i+1] - b[i])^2 > 1e-12) exit 1
    for (i = 4; i <= 7; i++) if ((sgn * a[i+1] - b[i])^2 > 1e-12) exit 1 }' || fail "pose '$1' != t($2 $3 $4) q($5 $6 $7 $8)"
}
check_pose "$(sed -n 2p "$tmp/kfv/poses.txt")" 1.1 2.5 3.05 -0.5 0.5 -0.5 0.5
check_pose "$(sed -n 3p "$tmp/kfv/poses.txt")" -0.5 0.1 0.05 -"$s" 0 0 "$s"
[ -e "$tmp/kfv/depth/2000000000.png" ] || fail "depth not carried over"
printf '# t x y z qx qy qz qw\n1.000000000 1 2 3 0 0 0 1\n' >"$tmp/vio_short.txt"
if bash "$tools/repro/vio_keyframes.sh" "$kf" "$tmp/vio_short.txt" "$tmp/cam0.yaml" "$tmp/kfx" 2>/dev/null; then
  fail "a keyframe without VIO pose was accepted"
fi

# merge_keyframes (crowd.sh needs the driver's die/say only).
started=$(date +%s)
# shellcheck source=../../tools/repro/lib.sh
. "$tools/repro/lib.sh"
# shellcheck source=../../tools/repro/crowd.sh
. "$tools/repro/crowd.sh"
merge_keyframes "$tmp/merged" "$kf" "$tmp/kfv"
[ "$(grep -vc '^#' "$tmp/merged/poses.txt")" = 4 ] || fail "merged poses: expected 4 lines"
[ "$(sed -n 4p "$tmp/merged/poses.txt" | cut -d' ' -f1)" = 1001.000000000 ] || fail "session 2 stamp not shifted by 1000 s"
[ -e "$tmp/merged/depth/1001000000000.png" ] && [ -e "$tmp/merged/depth/2000000000.png" ] || fail "merged depth names"

# report.sh on a hand-made results.json: two trials of one sequence.
cat >"$tmp/results.json" <<'EOJ'
{"preset":"tiny","sequences":["S1_01"],"noises":["small"],"trials":2,"city_seed":1,"th_f_m":[10,20],
 "free_ray_bounds_px":[128],"th_f_point_m":20,"commit":"abc","started":"s","finished":"f","loadavg_at_end":"1 1 1",
 "machine":{"cpu":"cpu","nproc":2,"loadavg_at_start":"1 1 1"},"crowd":null,
 "dataset_times":[{"preset":"tiny","sequence":"S1_01","render_s":10},{"preset":"tiny","sequence":"S1_01","render_s":20.4},
                  {"preset":"tiny","sequence":"S1_01","noise":"small","seed":2,"renoise_s":5}],
 "runs":[
  {"sequence":"S1_01","noise":"small","trial":1,"commit":"abc","ate_vio":{"rmse":0.4,"std":0.1,"max":0.8},"ate_fused":{"rmse":0.1,"std":0.05,"max":0.2},
   "client_timing":{"stages":[{"stage":"odometry","seconds":10,"calls":100,"ms_per_call":100}],"wall_s":12,"frames":100,"keyframes":10},
   "sweep":[{"free_ray_bound_px":128,"th_f_m":10,"detect_s":2,"paper":{"R_new":0.9,"P_new":0.8,"R_rm":0.7,"P_rm":0.6}},
            {"free_ray_bound_px":128,"th_f_m":20,"detect_s":4,"paper":{"R_new":1.0,"P_new":0.8,"R_rm":0.7,"P_rm":0.4}}],
   "vio_pose_changes":{"paper":{"R_new":0.5,"P_new":0.5,"R_rm":0.5,"P_rm":0.5}},"vio_pose_params":"th_f 20 m"},
  {"sequence":"S1_01","noise":"small","trial":2,"commit":"abc","detect_commit":"def","machine":{"cpu":"other","nproc":2},"ate_vio":{"rmse":0.6,"std":0.3,"max":1.0},"ate_fused":{"rmse":0.3,"std":0.15,"max":0.4},
   "client_timing":{"stages":[{"stage":"odometry","seconds":20,"calls":100,"ms_per_call":200}],"wall_s":22,"frames":100,"keyframes":10},
   "sweep":[{"free_ray_bound_px":128,"th_f_m":10,"detect_s":2,"paper":{"R_new":0.7,"P_new":0.6,"R_rm":0.5,"P_rm":0.4}},
            {"free_ray_bound_px":128,"th_f_m":20,"detect_s":4,"paper":{"R_new":0.8,"P_new":0.6,"R_rm":0.5,"P_rm":0.2}}],
   "vio_pose_changes":{"paper":{"R_new":0.3,"P_new":0.3,"R_rm":0.3,"P_rm":0.3}},"vio_pose_params":"th_f 20 m"}]}
EOJ
bash "$tools/repro/report.sh" "$tmp/results.json" "$tmp/report" 2>/dev/null
md=$tmp/report/report.md
# The last two columns are the paper's Table III for S1_01 small (PPCA-VINS, VINS-Fusion RMSE).
grep -qF '| S1_01 | small | 2 | 0.500 | 0.200 | 0.900 | 0.200 | 0.100 | 0.300 | 1.097 | 1.768 |' "$md" || fail "Table III row (means over 2 trials)"
grep -qF '| 10 | 0.800 | 0.700 | 0.600 | 0.500 | 2.0 | 2 |' "$md" || fail "th_f 10 row"
grep -qF 'Free-ray bound 128 px (the server'"'"'s default: a pixel without depth is free only up to the nearest depth within 128 px), small noise:' "$md" ||
  fail "th_f table heading per noise level"
grep -qF '| S1_01 | small | VIO only | 0.400 | 0.400 | 0.400 | 0.400 |' "$md" || fail "Fig. 6 VIO row"
grep -qF '| odometry | 150.0 | 100 | 15.0 |' "$md" || fail "timing row"
# Trial 1 has no machine (recorded before runs carried one), trial 2 ran on "other".
grep -qF 'Runs by machine: other (1), unrecorded (1).' "$md" || fail "runs by machine"
grep -qF 'By machine: other: client 22 s per run, mapdelta-detect 3 s per call (1 runs); unrecorded: client 12 s per run' "$md" ||
  fail "timings by machine"
grep -qF 'Datasets made by this run (wall time): tiny/S1_01 render 15 s (mean of 2), renoise 5 s.' "$md" || fail "dataset times"
for p in thf_b128 fig6; do [ -s "$tmp/report/plots/$p.png" ] || fail "plot $p.png missing"; done
# restore.sh: the two runs come back under their names, identical to the record but for the
# machine, which a run without one takes from the record; a second call keeps them; a file that
# is not a results.json is refused.
bash "$tools/repro/restore.sh" "$tmp/results.json" "$tmp/restored" 2>/dev/null
jq -e --slurpfile r "$tmp/results.json" '. == ($r[0].runs[0] + {machine: {cpu: "cpu", nproc: 2}})' \
  "$tmp/restored/runs/S1_01-small-t1/run.json" >/dev/null || fail "restored run.json of trial 1 (machine from the record)"
jq -e --slurpfile r "$tmp/results.json" '. == $r[0].runs[1]' \
  "$tmp/restored/runs/S1_01-small-t2/run.json" >/dev/null || fail "restored run.json of trial 2 (its own machine)"
bash "$tools/repro/restore.sh" "$tmp/results.json" "$tmp/restored" 2>&1 | grep -q '0 run(s) restored' || fail "restore twice"
if bash "$tools/repro/restore.sh" "$md" "$tmp/restored2" 2>/dev/null; then fail "restore accepted a Markdown file"; fi
grep -qF 'Runs by commit: `abc` (1), `abc, detection def` (1).' "$md" || fail "runs by commit (client, detection)"
# A crowd-only record (--trials 0) has no runs: the report still renders.
jq '.runs = [] | .trials = 0' "$tmp/results.json" >"$tmp/results_crowd_only.json"
bash "$tools/repro/report.sh" "$tmp/results_crowd_only.json" "$tmp/report_crowd_only" 2>/dev/null ||
  fail "report of a record without runs"
# A record of operating points only (--sweep-trials 0) says so instead of an empty th_f table.
jq '.sweep_trials = 0 | .runs[] |= (.full_sweep = false | .sweep |= map(select(.th_f_m == 20)))' "$tmp/results.json" \
  >"$tmp/results_no_sweep.json"
bash "$tools/repro/report.sh" "$tmp/results_no_sweep.json" "$tmp/report_no_sweep" 2>/dev/null
grep -qF 'No th_f sweep in this record (`--sweep-trials 0`)' "$tmp/report_no_sweep/report.md" &&
  grep -qF 'No run in this record swept th_f.' "$tmp/report_no_sweep/report.md" || fail "report without a sweep: the note"
if grep -qF 'Per sequence (mean over trials):' "$tmp/report_no_sweep/report.md"; then fail "report without a sweep: empty table"; fi
grep -qF '| S1_01 | small | fused | 0.900 |' "$tmp/report_no_sweep/report.md" || fail "report without a sweep: Fig. 6 row"
bash "$tools/repro/compare.sh" "$tmp/results.json" "$tmp/results.json" >"$tmp/compare.md"
grep -qF 'after: rule paper, commit(s) abc, abc (detection def).' "$tmp/compare.md" || fail "compare: commits"
grep -qF '| S1_01 | small | 2 | 0.2 → 0.2 | 0.9 → 0.9 | 0.7 → 0.7 | 0.6 → 0.6 | 0.3 → 0.3 |' "$tmp/compare.md" ||
  fail "compare: means over the trials"

# --redetect: forget_detection drops the record and every detection, keeps the client output and
# the commit that made it; client_done sees the finished client.
run=$tmp/runs/S1_01-small-t1
mkdir -p "$run/client/keyframes" "$run/detect/b128-thf20" "$run/detect-vio" "$run/detect-rule-paper"
: >"$run/client/timing.txt"
: >"$run/client/fused.txt"
echo '{"commit":"abc"}' >"$run/run.json"
client_done "$run" || fail "client_done: a finished client"
forget_detection "$run"
[ ! -e "$run/run.json" ] && [ ! -e "$run/detect" ] && [ ! -e "$run/detect-vio" ] && [ ! -e "$run/detect-rule-paper" ] ||
  fail "forget_detection left a detection"
[ -d "$run/client/keyframes" ] && [ "$(cat "$run/client/commit")" = abc ] || fail "forget_detection: client output or its commit"
rm "$run/client/fused.txt"
if client_done "$run"; then fail "client_done: a client without fused.txt"; fi
# A pruned trial (info.json, no images) serves a finished client; the client itself needs images.
data=$tmp/data city_seed=1 out=$tmp bin_sim=false nice_cmd="" log=$tmp/log.txt
mkdir -p "$data/paper-small-s1-n1/sequences/S1_01"
echo '{}' >"$data/paper-small-s1-n1/sequences/S1_01/info.json"
declare -A dataset_override=()
[ "$(ensure_dataset paper small 1 S1_01 0)" = "$data/paper-small-s1-n1" ] || fail "ensure_dataset: pruned trial, client done"
if (ensure_dataset paper small 1 S1_01 1 2>/dev/null); then fail "ensure_dataset: pruned trial served a client run"; fi
# Two reproductions sharing --data reach an unrendered sequence together (one per noise level):
# one renders it, the other waits and renoises from it. The stand-in simulator takes a second per
# render, so without the lock both would render into one folder.
cat >"$tmp/fake-sim" <<'EOF2'
#!/usr/bin/env bash
out="" seq=""
[ "$1" = renoise ] && { mode=renoise; shift; } || mode=render
while [ $# -gt 0 ]; do
  case $1 in --out) out=$2; shift 2 ;; --sequences) seq=$2; shift 2 ;; *) shift ;; esac
done
if [ "$mode" = render ]; then
  echo "$seq" >>"$(dirname "$out")/renders.txt"
  sleep 1
fi
mkdir -p "$out/sequences/$seq/mav0/cam1/data"
echo '{}' >"$out/sequences/$seq/info.json"
EOF2
chmod +x "$tmp/fake-sim"
bin_sim=$tmp/fake-sim started=$(date +%s)
ensure_dataset paper small 2 S1_02 >"$tmp/small.txt" 2>/dev/null &
ensure_dataset paper big 2 S1_02 >"$tmp/big.txt" 2>/dev/null &
wait
[ "$(cat "$data/renders.txt")" = S1_02 ] || fail "ensure_dataset: rendered $(wc -l <"$data/renders.txt") times for two reproductions"
[ "$(cat "$tmp/small.txt")" = "$data/paper-small-s1-n2" ] && [ "$(cat "$tmp/big.txt")" = "$data/paper-big-s1-n2" ] &&
  [ -f "$data/paper-big-s1-n2/sequences/S1_02/info.json" ] || fail "ensure_dataset: the waiting reproduction's trial"
echo "repro helpers: all checks passed"

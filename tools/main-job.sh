#!/usr/bin/env bash
# The README's main job: the whole mapdelta loop on a generated dataset, end to end.
#   dataset (mapdelta-sim) -> server (SQLite) with the original scene as prior ->
#   two vehicle clients (VIO + depth + registration + fusion + upload) -> commits ->
#   changed tiles over REST -> evaluation (ATE, paper metrics) -> clean server stop.
set -euo pipefail

usage() {
  cat <<'EOF'
usage: bash tools/main-job.sh [options]
  --out DIR          working folder (default out/demo); wiped at start
  --build-dir DIR    CMake build folder (default build)
  --no-build         use binaries already built in --build-dir (skip deps and build)
  --preset NAME      mapdelta-sim preset (default tiny)
  --seed N           dataset and noise seed (default 1)
  --noise NAME       sensor noise: none | small | big (default small)
  --sequences LIST   comma-separated sequences to drive (default S1_01,S2_01)
  --dataset DIR      use this already generated dataset instead of generating one
  --json FILE        also write the summary as JSON to FILE (default OUT/summary.json)
  --help             this text
EOF
}

root=$(cd "$(dirname "$0")/.." && pwd)
out=out/demo
build_dir=build
do_build=1
preset=tiny
seed=1
noise=small
sequences=S1_01,S2_01
json=""
dataset=""
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out=$2; shift 2 ;;
    --build-dir) build_dir=$2; shift 2 ;;
    --no-build) do_build=0; shift ;;
    --preset) preset=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --noise) noise=$2; shift 2 ;;
    --sequences) sequences=$2; shift 2 ;;
    --json) json=$2; shift 2 ;;
    --dataset) dataset=$2; shift 2 ;;
    --help|-h) usage; exit 0 ;;
    *) echo "main-job: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
cd "$root"
case "$out" in /*) ;; *) out="$root/$out" ;; esac
case "$build_dir" in /*) ;; *) build_dir="$root/$build_dir" ;; esac
[ -n "$json" ] || json="$out/summary.json"

total_steps=7
step_no=0
started=$(date +%s)
step() {
  step_no=$((step_no + 1))
  printf '\n==> [%d/%d] %s  (%ds)\n' "$step_no" "$total_steps" "$1" $(($(date +%s) - started)) >&2
}

server_pid=""
stop_server() {
  if [ -n "$server_pid" ] && kill -0 "$server_pid" 2>/dev/null; then
    kill -TERM "$server_pid"
    wait "$server_pid" || true
  fi
  server_pid=""
}
trap stop_server EXIT

# ---------------------------------------------------------------------------------------------
step "install dependencies and build"
if [ "$do_build" = 1 ]; then
  "$root/deploy/install-deps.sh"
  export CCACHE_BASEDIR=$root
  cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$build_dir" -j "$(nproc)" --target mapdelta-sim mapdelta-server mapdelta-client \
    mapdelta-eval mapdelta-detect
fi
sim=$build_dir/sim/mapdelta-sim
server=$build_dir/server/mapdelta-server
client=$build_dir/client/mapdelta-client
eval_tool=$build_dir/tools/mapdelta-eval
detect=$build_dir/tools/mapdelta-detect
for bin in "$sim" "$server" "$client" "$eval_tool" "$detect"; do
  [ -x "$bin" ] || { echo "main-job: missing binary $bin (build first)" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out"

# ---------------------------------------------------------------------------------------------
if [ -n "$dataset" ]; then
  step "use the dataset in $dataset"
  case "$dataset" in /*) ;; *) dataset="$root/$dataset" ;; esac
else
  step "generate the '$preset' dataset (seed $seed, noise $noise)"
  dataset=$out/dataset
  "$sim" --preset "$preset" --out "$dataset" --seed "$seed" --noise "$noise" \
    --sequences "$sequences"
fi

# ---------------------------------------------------------------------------------------------
step "start the server (SQLite in $out/server) and import the original scene as prior"
mkdir -p "$out/server"
cat >"$out/server/server.yaml" <<EOF
http:
  listen_address: 127.0.0.1
  port: 0
storage:
  database: $out/server/mapdelta.db
log:
  level: warn
  format: text
EOF
config=$out/server/server.yaml
token_of() {  # role name -> secret
  "$server" token create --config "$config" --role "$1" --name "$2" | sed -n 's/^token: //p'
}
admin_token=$(token_of admin demo-admin)
vehicle_token=$(token_of vehicle demo-vehicle)
reader_token=$(token_of reader demo-reader)

"$server" serve --config "$config" >"$out/server/stdout.log" 2>"$out/server/server.log" &
server_pid=$!
for _ in $(seq 1 100); do
  grep -q '^listening on' "$out/server/stdout.log" 2>/dev/null && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$out/server/server.log" >&2; exit 1; }
  sleep 0.1
done
address=$(sed -n 's/^listening on //p' "$out/server/stdout.log")
[ -n "$address" ] || { echo "main-job: server did not start" >&2; exit 1; }
url="http://$address"
echo "server at $url" >&2

api() {  # METHOD PATH TOKEN [curl args...]
  local method=$1 path=$2 token=$3
  shift 3
  curl -sS --fail-with-body -X "$method" -H "Authorization: Bearer $token" "$@" "$url$path"
}
api POST "/v1/admin/prior?format=pcd" "$admin_token" \
  -H 'Content-Type: application/octet-stream' \
  --data-binary "@$dataset/scenes/original/cloud.pcd" | jq -c '{prior_version, tiles: (.tiles // .tile_count)}' >&2

# ---------------------------------------------------------------------------------------------
step "drive the vehicles: VIO, stereo depth, temporal filter, GICP to prior tiles, fusion, upload"
IFS=, read -r -a seq_list <<<"$sequences"
for seq in "${seq_list[@]}"; do
  echo "--- vehicle on $seq" >&2
  "$client" run --sequence "$dataset/sequences/$seq" --odometry vio \
    --server "$url" --token "$vehicle_token" --out "$out/clients/$seq"
done

# ---------------------------------------------------------------------------------------------
step "wait for the server's commit jobs (aggregation and classification)"
for _ in $(seq 1 600); do
  pending=$(api GET "/v1/admin/jobs" "$admin_token" |
    jq '[.jobs[] | select(.state == "queued" or .state == "running")] | length')
  [ "$pending" = 0 ] && break
  sleep 0.5
done
api GET "/v1/admin/jobs" "$admin_token" |
  jq -r '.jobs[] | "job \(.job_id) \(.type) \(.state)"' >&2

# ---------------------------------------------------------------------------------------------
step "evaluate every sequence: ATE (VIO alone, fused) and the paper's change metrics"
original_cloud=$dataset/scenes/original/cloud.pcd
results="[]"
for seq in "${seq_list[@]}"; do
  scene=${seq%%_*}
  gt=$dataset/sequences/$seq/mav0/state_groundtruth_estimate0/data.csv
  client_out=$out/clients/$seq
  "$eval_tool" ate "$gt" "$client_out/vio.txt" --json "$client_out/ate_vio.json" >/dev/null
  "$eval_tool" ate "$gt" "$client_out/fused.txt" --json "$client_out/ate_fused.json" >/dev/null
  "$detect" --prior "$original_cloud" --keyframes "$client_out/keyframes" \
    --out "$client_out/detect" --free-ray-bound 128 >/dev/null
  "$eval_tool" changes --original "$original_cloud" --changed "$dataset/scenes/$scene/cloud.pcd" \
    --new "$client_out/detect/new.pcd" --removed "$client_out/detect/removed.pcd" \
    --global "$client_out/detect/global.pcd" --observed "$client_out/detect/observed.bt" \
    --json "$client_out/changes.json" >/dev/null
  results=$(jq -c --arg seq "$seq" \
    --slurpfile vio "$client_out/ate_vio.json" --slurpfile fused "$client_out/ate_fused.json" \
    --slurpfile changes "$client_out/changes.json" \
    '. + [{sequence: $seq, ate_vio: $vio[0], ate_fused: $fused[0], changes: $changes[0]}]' \
    <<<"$results")
done

# ---------------------------------------------------------------------------------------------
step "query the changed tiles over REST and stop the server"
tiles=$(api GET "/v1/changes/tiles?bbox=-100000,-100000,100000,100000&page_size=500" "$reader_token")
stop_server

jq -n --argjson sequences "$results" --argjson tiles "$tiles" \
  '{sequences: $sequences, changed_tiles: $tiles}' >"$json"

printf '\n%-8s %12s %12s %8s %8s %8s %8s\n' sequence ATE_vio_m ATE_fused_m R_new P_new R_rm P_rm
jq -r '.sequences[] | [.sequence, .ate_vio.rmse, .ate_fused.rmse, .changes.paper.R_new,
  .changes.paper.P_new, .changes.paper.R_rm, .changes.paper.P_rm] |
  "\(.[0]) \(.[1]) \(.[2]) \(.[3]) \(.[4]) \(.[5]) \(.[6])"' "$json" |
  while read -r s a f rn pn rr pr; do
    printf '%-8s %12.3f %12.3f %8.3f %8.3f %8.3f %8.3f\n' "$s" "$a" "$f" "$rn" "$pn" "$rr" "$pr"
  done
printf '\nchanged tiles (prior version %s):\n' "$(jq -r '.changed_tiles.prior_version // "?"' "$json")"
printf '%-10s %8s %8s %11s  %s\n' tile new removed confidence updated
jq -r '.changed_tiles.tiles[] | "\(.tile) \(.new_count) \(.removed_count) \(.max_confidence) \(.updated_at)"' \
  "$json" | while read -r t n r c u; do
  printf '%-10s %8s %8s %11.2f  %s\n' "$t" "$n" "$r" "$c" "$u"
done
printf '\nsummary: %s   total time %ds\n' "$json" $(($(date +%s) - started))

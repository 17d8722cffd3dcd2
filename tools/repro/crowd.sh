# Crowdsourcing experiment of tools/reproduce-paper.sh (sourced; uses lib.sh and the driver's
# variables). One server; the same changed scene driven max(N) times with noise seeds 1..max,
# upload i by its own vehicle (vehicle_id crowd-car-i) on the i-th of the --crowd-sequence list
# (round robin); after N uploads the server's aggregated changes are evaluated with the paper's
# metrics: all points, those with confidence > 0.5 (supported by a majority of the sessions that
# observed them), and those of confirmed change clusters (issue #20's lifecycle, the server's
# lifecycle.* defaults). P_g and A_obs for the evaluation come from mapdelta-detect on the N
# sessions' keyframes merged, whose own offline detection is reported beside the server's.
# With --crowd-replay FROM the uploads are FROM's keyframe folders sent again with
# `mapdelta-client upload` (the server registers and classifies them anew), and FROM's merged
# detections stand in for P_g / A_obs: the same sessions through another server build in minutes.

crowd_server_pid=""
crowd_stop_server() {
  if [ -n "$crowd_server_pid" ] && kill -0 "$crowd_server_pid" 2>/dev/null; then
    kill -TERM "$crowd_server_pid"
    wait "$crowd_server_pid" || true
  fi
  crowd_server_pid=""
}

crowd_api() {  # METHOD PATH TOKEN [curl args...]
  local method=$1 path=$2 token=$3
  shift 3
  curl -sS --fail-with-body -X "$method" -H "Authorization: Bearer $token" "$@" "$crowd_url$path"
}

crowd_wait_jobs() {
  local pending
  for _ in $(seq 1 3600); do
    pending=$(crowd_api GET "/v1/admin/jobs?page_size=500" "$crowd_admin" |
      jq '[.jobs[] | select(.state == "queued" or .state == "running")] | length')
    [ "$pending" = 0 ] && return
    sleep 0.5
  done
  die "server jobs did not finish within 30 min"
}

# ascii_pcd FILE < "x y z" lines
ascii_pcd() {
  local tmp; tmp=$(mktemp)
  cat >"$tmp"
  local n; n=$(wc -l <"$tmp")
  {
    printf '# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n'
    printf 'WIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA ascii\n' "$n" "$n"
    cat "$tmp"
  } >"$1"
  rm -f "$tmp"
}

# merge_keyframes OUT DIR... : one keyframe folder from several sessions; session i's stamps
# are shifted by i*1000 s so they stay unique and increasing.
merge_keyframes() {
  local dst=$1
  shift
  rm -rf "$dst"
  mkdir -p "$dst/depth"
  cp "$1/camera.yaml" "$dst/camera.yaml"
  echo "# t x y z qx qy qz qw  (T_map_cam)" >"$dst/poses.txt"
  local i=0 src f t
  for src in "$@"; do
    cmp -s "$src/camera.yaml" "$dst/camera.yaml" || die "$src/camera.yaml differs from $1/camera.yaml"
    awk -v off="$((i * 1000))" '!/^#/ && NF == 8 { split($1, s, "."); $1 = (s[1] + off) "." s[2]; print }' \
      "$src/poses.txt" >>"$dst/poses.txt"
    for f in "$src"/depth/*.png; do
      t=$(basename "$f" .png)
      ln -f "$f" "$dst/depth/$((t + i * 1000000000000)).png" 2>/dev/null || cp "$f" "$dst/depth/$((t + i * 1000000000000)).png"
    done
    i=$((i + 1))
  done
}

crowd_snapshot() {
  local n=$1 ds=$2
  local dir=$out/crowd/N$n
  [ -f "$dir/snapshot.json" ] && return
  mkdir -p "$dir"
  say "crowd: evaluate the server's changes after $n upload(s)"
  local tiles
  tiles=$(crowd_api GET "/v1/changes/tiles?bbox=-100000,-100000,100000,100000&page_size=500" "$crowd_reader")
  echo "$tiles" >"$dir/tiles.json"
  : >"$dir/points.jsonl"
  : >"$dir/confirmed.jsonl"
  local points='(.new[] | {kind: "new", p, confidence, observed: (.observed_by | length), supported: (.supported_by | length)}),
                (.removed[] | {kind: "removed", p, confidence, observed: (.observed_by | length), supported: (.supported_by | length)})'
  for t in $(jq -r '.tiles[].tile' <<<"$tiles"); do
    crowd_api GET "/v1/changes/tiles/$t?format=json" "$crowd_reader" | jq -c "$points" >>"$dir/points.jsonl"
    crowd_api GET "/v1/changes/tiles/$t?format=json&state=confirmed,applied" "$crowd_reader" |
      jq -c "$points" >>"$dir/confirmed.jsonl"
  done
  local page=1 got total
  : >"$dir/clusters.jsonl"
  while :; do  # every cluster, in pages of 1000
    got=$(crowd_api GET "/v1/changes/clusters?page_size=1000&page=$page" "$crowd_reader")
    jq -c '.clusters[]' <<<"$got" >>"$dir/clusters.jsonl"
    total=$(jq '.total' <<<"$got")
    [ "$(wc -l <"$dir/clusters.jsonl")" -ge "$total" ] || [ "$(jq '.clusters | length' <<<"$got")" = 0 ] && break
    page=$((page + 1))
  done
  jq -s '{clusters: .}' "$dir/clusters.jsonl" >"$dir/clusters.json"
  rm -f "$dir/clusters.jsonl"
  for kind in new removed; do
    jq -r --arg k "$kind" 'select(.kind == $k) | .p | map(tostring) | join(" ")' "$dir/points.jsonl" | ascii_pcd "$dir/server_all_$kind.pcd"
    jq -r --arg k "$kind" 'select(.kind == $k and .confidence > 0.5) | .p | map(tostring) | join(" ")' "$dir/points.jsonl" |
      ascii_pcd "$dir/server_majority_$kind.pcd"
    jq -r --arg k "$kind" 'select(.kind == $k) | .p | map(tostring) | join(" ")' "$dir/confirmed.jsonl" |
      ascii_pcd "$dir/server_confirmed_$kind.pcd"
  done
  local kfs=() i from=${crowd_replay:+$crowd_replay/crowd/N$n/merged}
  if [ -n "$from" ] && [ -f "$from/changes.json" ] && [ -f "$from/global.pcd" ] && [ -f "$from/observed.bt" ]; then
    mkdir -p "$dir/merged"
    for f in changes.json summary.json time_s global.pcd observed.bt new.pcd removed.pcd; do
      [ -f "$from/$f" ] && ln -f "$from/$f" "$dir/merged/$f"
    done
  else
    for i in $(seq 1 "$n"); do kfs+=("$out/crowd/u$i/keyframes"); done
    merge_keyframes "$dir/keyframes" "${kfs[@]}"
    detect_and_eval_keep "$ds" "$crowd_seq" "$dir/keyframes" "$dir/merged" "$thf_point" "$operating_bound"
  fi
  local scene=${crowd_seq%%_*} which
  for which in all majority confirmed; do
    "$bin_eval" changes --original "$ds/scenes/original/cloud.pcd" --changed "$ds/scenes/$scene/cloud.pcd" \
      --new "$dir/server_${which}_new.pcd" --removed "$dir/server_${which}_removed.pcd" \
      --global "$dir/merged/global.pcd" --observed "$dir/merged/observed.bt" \
      --json "$dir/changes_server_$which.json" >/dev/null 2>>"$log" || die "mapdelta-eval failed in $dir (see $log)"
  done
  jq -n --argjson n "$n" --slurpfile a "$dir/changes_server_all.json" --slurpfile m "$dir/changes_server_majority.json" \
    --slurpfile c "$dir/changes_server_confirmed.json" --slurpfile o "$dir/merged/changes.json" \
    --argjson tiles "$(jq '[.tiles[] | {tile, new_count, removed_count, max_confidence}]' "$dir/tiles.json")" \
    --argjson clusters "$(jq '[.clusters[] | {kind, state, point_count}] | group_by([.kind, .state]) |
                             map({kind: .[0].kind, state: .[0].state, clusters: length, points: (map(.point_count) | add)})' "$dir/clusters.json")" \
    '{uploads: $n, server_all: $a[0].paper, server_majority: $m[0].paper, server_confirmed: $c[0].paper,
      offline_merged: $o[0].paper, changed_tiles: $tiles, clusters: $clusters}' \
    >"$dir/snapshot.json"
  rm -rf "$dir/keyframes"
  # The merged clouds stay (one pair per snapshot): a --crowd-replay of this run evaluates with them.
  say "  server (all): $(jq -c '.server_all | {R_new, P_new, R_rm, P_rm} | map_values(. * 1000 | round / 1000)' "$dir/snapshot.json")"
  say "  server (confirmed): $(jq -c '.server_confirmed | {R_new, P_new, R_rm, P_rm} | map_values(if . == null then null else . * 1000 | round / 1000 end)' "$dir/snapshot.json")"
}

# As detect_and_eval, but keeps global.pcd and observed.bt (the server evaluation needs them).
detect_and_eval_keep() {
  local saved=$keep_data
  keep_data=1
  detect_and_eval "$@"
  keep_data=$saved
}

crowd_experiment() {
  local max=0 n
  for n in ${crowd//,/ }; do [ "$n" -gt "$max" ] && max=$n; done
  local cdir=$out/crowd
  if [ -f "$cdir/crowd.json" ]; then say "crowd: done earlier, kept"; return; fi
  rm -rf "$cdir/server"
  mkdir -p "$cdir/server"
  say "crowd: server on a fresh SQLite database, prior = original scene ($crowd_preset)"
  cat >"$cdir/server/server.yaml" <<EOF3
http:
  listen_address: 127.0.0.1
  port: 0
storage:
  database: $cdir/server/mapdelta.db
log:
  level: warn
  format: text
EOF3
  local config=$cdir/server/server.yaml
  token_of() { "$bin_server" token create --config "$config" --role "$1" --name "$2" | sed -n 's/^token: //p'; }
  crowd_admin=$(token_of admin repro-admin)
  local vehicle; vehicle=$(token_of vehicle repro-vehicle)
  crowd_reader=$(token_of reader repro-reader)
  "$bin_server" serve --config "$config" >"$cdir/server/stdout.log" 2>"$cdir/server/server.log" &
  crowd_server_pid=$!
  trap crowd_stop_server EXIT
  for _ in $(seq 1 100); do
    grep -q '^listening on' "$cdir/server/stdout.log" 2>/dev/null && break
    kill -0 "$crowd_server_pid" 2>/dev/null || die "server did not start (see $cdir/server/server.log)"
    sleep 0.1
  done
  crowd_url="http://$(sed -n 's/^listening on //p' "$cdir/server/stdout.log")"
  local seqs; IFS=, read -r -a seqs <<<"$crowd_seq"
  local ds1=$data/clean-$crowd_preset-s$city_seed
  [ -n "$crowd_replay" ] || ds1=$(ensure_dataset "$crowd_preset" "$crowd_noise" 1 "${seqs[0]}")
  crowd_api POST "/v1/admin/prior?format=pcd" "$crowd_admin" -H 'Content-Type: application/octet-stream' \
    --data-binary "@$ds1/scenes/original/cloud.pcd" >/dev/null
  local i ds seq
  for i in $(seq 1 "$max"); do
    seq=${seqs[$(((i - 1) % ${#seqs[@]}))]}
    rm -rf "$cdir/u$i"
    printf 'upload:\n  vehicle_id: crowd-car-%d\n' "$i" >"$cdir/u$i.yaml"
    # A replay sends the earlier run's uploads again; uploads past its last run fresh.
    if [ -n "$crowd_replay" ] && [ -d "$crowd_replay/crowd/u$i" ]; then
      ds=$data/clean-$crowd_preset-s$city_seed  # only its scene clouds are read
      [ -f "$ds/scenes/original/cloud.pcd" ] || die "--crowd-replay: no $ds/scenes/original/cloud.pcd (use the run's --data)"
      local src=$crowd_replay/crowd/u$i
      [ -f "$src/keyframes/poses.txt" ] || die "--crowd-replay: no $src/keyframes/poses.txt"
      say "crowd: upload $i/$max again (keyframes of $src, vehicle crowd-car-$i): upload, commit"
      mkdir -p "$cdir/u$i"
      cp -al "$src/keyframes" "$cdir/u$i/keyframes"
      cp "$src/timing.txt" "$cdir/u$i/timing.txt"
      "$bin_client" upload "$cdir/u$i/keyframes" --server "$crowd_url" --token "$vehicle" \
        --config "$cdir/u$i.yaml" >"$cdir/u$i.log" 2>&1 || die "upload failed (see $cdir/u$i.log)"
    else
      ds=$(ensure_dataset "$crowd_preset" "$crowd_noise" "$i" "$seq")
      say "crowd: upload $i/$max ($seq, noise seed $i, vehicle crowd-car-$i): client with the server's prior tiles, upload, commit"
      $nice_cmd "$bin_client" run --sequence "$ds/sequences/$seq" --odometry vio --server "$crowd_url" \
        --token "$vehicle" --config "$cdir/u$i.yaml" --out "$cdir/u$i" >"$cdir/u$i.log" 2>&1 ||
        die "client failed (see $cdir/u$i.log)"
    fi
    crowd_wait_jobs
    [[ ",$crowd," == *",$i,"* ]] && crowd_snapshot "$i" "$ds"
    prune_dataset "$ds" "$seq"
  done
  crowd_api GET "/v1/admin/jobs?page_size=500" "$crowd_admin" >"$cdir/jobs.json"
  crowd_stop_server
  local snaps
  snaps=$(for n in ${crowd//,/ }; do cat "$cdir/N$n/snapshot.json"; done | jq -s '.')
  jq -n --argjson snaps "$snaps" --slurpfile jobs "$cdir/jobs.json" --arg preset "$crowd_preset" --arg seq "$crowd_seq" \
    --argjson timing "$(for i in $(seq 1 "$max"); do timing_json "$cdir/u$i"; done | jq -s '.')" \
    '{preset: $preset, sequence: $seq, snapshots: $snaps, client_timing: $timing,
      commit_jobs: [$jobs[0].jobs[] | select(.type == "commit") | {job_id, state, created_at, started_at, finished_at, result}]}' \
    >"$cdir/crowd.json"
}

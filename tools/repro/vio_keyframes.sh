#!/usr/bin/env bash
# usage: vio_keyframes.sh KEYFRAMES_DIR VIO_TUM CAM0_SENSOR_YAML OUT_DIR
# A copy of a client's keyframe folder whose poses are the VIO-alone poses instead of the fused
# ones: T_map_cam = T_map_body(vio) * T_body_cam0 (T_BS of cam0/sensor.yaml). Depth images are
# hard links. The paper's Fig. 6 compares change detection from these against the fused poses.
set -euo pipefail
[ $# -eq 4 ] || { sed -n '2,5p' "$0" >&2; exit 2; }
kf=$1 vio=$2 yaml=$3 out=$4
for f in "$kf/poses.txt" "$kf/camera.yaml" "$vio" "$yaml"; do
  [ -f "$f" ] || { echo "vio_keyframes: $f: missing" >&2; exit 1; }
done
tbs=$(tr '\n' ' ' <"$yaml" | sed -n 's/.*T_BS:.*data: *\[\([^]]*\)\].*/\1/p' | tr -d ',')
[ "$(wc -w <<<"$tbs")" = 16 ] || { echo "vio_keyframes: $yaml: T_BS data must have 16 numbers" >&2; exit 1; }
rm -rf "$out"
mkdir -p "$out/depth"
cp "$kf/camera.yaml" "$out/camera.yaml"
for d in "$kf"/depth/*.png; do ln -f "$d" "$out/depth/" 2>/dev/null || cp "$d" "$out/depth/"; done
awk -v tbs="$tbs" '
  function q2r(qx, qy, qz, qw, R,   n) {
    n = sqrt(qx*qx + qy*qy + qz*qz + qw*qw); qx /= n; qy /= n; qz /= n; qw /= n
    R[1,1] = 1 - 2*(qy*qy + qz*qz); R[1,2] = 2*(qx*qy - qz*qw); R[1,3] = 2*(qx*qz + qy*qw)
    R[2,1] = 2*(qx*qy + qz*qw); R[2,2] = 1 - 2*(qx*qx + qz*qz); R[2,3] = 2*(qy*qz - qx*qw)
    R[3,1] = 2*(qx*qz - qy*qw); R[3,2] = 2*(qy*qz + qx*qw); R[3,3] = 1 - 2*(qx*qx + qy*qy)
  }
  # Rotation matrix -> quaternion (Shepperd: divide by the largest component).
  function r2q(R, Q,   tr, s) {
    tr = R[1,1] + R[2,2] + R[3,3]
    if (tr > 0) { s = 2*sqrt(tr + 1); Q["w"] = s/4; Q["x"] = (R[3,2]-R[2,3])/s; Q["y"] = (R[1,3]-R[3,1])/s; Q["z"] = (R[2,1]-R[1,2])/s }
    else if (R[1,1] > R[2,2] && R[1,1] > R[3,3]) { s = 2*sqrt(1 + R[1,1] - R[2,2] - R[3,3]); Q["w"] = (R[3,2]-R[2,3])/s; Q["x"] = s/4; Q["y"] = (R[1,2]+R[2,1])/s; Q["z"] = (R[1,3]+R[3,1])/s }
    else if (R[2,2] > R[3,3]) { s = 2*sqrt(1 + R[2,2] - R[1,1] - R[3,3]); Q["w"] = (R[1,3]-R[3,1])/s; Q["x"] = (R[1,2]+R[2,1])/s; Q["y"] = s/4; Q["z"] = (R[2,3]+R[3,2])/s }
    else { s = 2*sqrt(1 + R[3,3] - R[1,1] - R[2,2]); Q["w"] = (R[2,1]-R[1,2])/s; Q["x"] = (R[1,3]+R[3,1])/s; Q["y"] = (R[2,3]+R[3,2])/s; Q["z"] = s/4 }
  }
  BEGIN {
    split(tbs, m, " ")
    for (i = 1; i <= 3; i++) { for (j = 1; j <= 3; j++) Rbc[i,j] = m[(i-1)*4 + j]; tbc[i] = m[(i-1)*4 + 4] }
  }
  FNR == NR { if ($0 !~ /^#/ && NF == 8) { vio[sprintf("%.6f", $1)] = $0 } ; next }
  /^#/ { print; next }
  NF == 8 {
    key = sprintf("%.6f", $1)
    if (!(key in vio)) { printf "vio_keyframes: no VIO pose at keyframe t=%s\n", $1 > "/dev/stderr"; bad = 1; exit 1 }
    split(vio[key], v, " ")
    q2r(v[5], v[6], v[7], v[8], Rmb)
    for (i = 1; i <= 3; i++) {
      for (j = 1; j <= 3; j++) Rmc[i,j] = Rmb[i,1]*Rbc[1,j] + Rmb[i,2]*Rbc[2,j] + Rmb[i,3]*Rbc[3,j]
      t[i] = Rmb[i,1]*tbc[1] + Rmb[i,2]*tbc[2] + Rmb[i,3]*tbc[3] + v[i+1]
    }
    r2q(Rmc, Q)
    printf "%s %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", $1, t[1], t[2], t[3], Q["x"], Q["y"], Q["z"], Q["w"]
  }
  END { if (bad) exit 1 }
' "$vio" "$kf/poses.txt" >"$out/poses.txt"

#!/usr/bin/env bash
# Checks the main job's summary.json: every driven sequence must find its scene's changes
# (the paper's four metrics above the floors below) and prior-assisted fusion must not lose
# to VIO alone. Floors, and why (measured 2026-12-01, tiny seed 1 small noise: S1_01 / S2_01
# R_new 0.93 / 0.99, P_new 0.88 / 0.89, R_rm 0.99 / 1.00, P_rm 0.79 / 0.61; the VIO's solver
# has wall-time caps, so figures move a little with machine load: the floors keep a margin):
#   R_new, R_rm >= 0.80  the changed buildings are in full view of the tiny trajectories
#                        (the simulator's visibility test checks that), so most of their
#                        observed points must be found; the paper reports 0.6-0.95.
#   P_new >= 0.70        new points are the class most hurt by pose error (paper Sec. V-C);
#                        with prior-fused poses most must lie on the added building.
#   P_rm  >= 0.45        removed precision depends on free-space rays through walls that
#                        stereo could not match (paper Fig. 4: 0.2-0.6 at th_f 15-20 m); the
#                        free-ray bound (docs/api.md) lifts it above the paper's values.
#   fused ATE < VIO ATE  prior-assisted fusion must improve on VIO alone (issue 7).
# At least one changed tile must be reported by the server.
set -euo pipefail
summary=$1
min_recall=${E2E_MIN_RECALL:-0.80}
min_p_new=${E2E_MIN_P_NEW:-0.70}
min_p_rm=${E2E_MIN_P_RM:-0.45}

failures=$(jq -r --argjson mr "$min_recall" --argjson mpn "$min_p_new" --argjson mpr "$min_p_rm" '
  .sequences[] as $s
  | [ (if $s.changes.paper.R_new < $mr then "R_new \($s.changes.paper.R_new) < \($mr)" else empty end),
      (if $s.changes.paper.R_rm < $mr then "R_rm \($s.changes.paper.R_rm) < \($mr)" else empty end),
      (if $s.changes.paper.P_new < $mpn then "P_new \($s.changes.paper.P_new) < \($mpn)" else empty end),
      (if $s.changes.paper.P_rm < $mpr then "P_rm \($s.changes.paper.P_rm) < \($mpr)" else empty end),
      (if $s.ate_fused.rmse >= $s.ate_vio.rmse
         then "fused ATE \($s.ate_fused.rmse) >= VIO ATE \($s.ate_vio.rmse)" else empty end) ]
  | .[] | "\($s.sequence): \(.)"' "$summary")
tiles=$(jq '[.changed_tiles.tiles[] | select(.new_count + .removed_count > 0)] | length' "$summary")
[ "$tiles" -gt 0 ] || failures+=$'\n'"server reported no changed tile"
if [ -n "$failures" ]; then
  echo "e2e check FAILED:"
  echo "$failures"
  exit 1
fi
echo "e2e check passed: $(jq '.sequences | length' "$summary") sequences, $tiles changed tiles"

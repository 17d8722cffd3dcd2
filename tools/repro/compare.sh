#!/usr/bin/env bash
# Two reproductions' results.json side by side (issue 21's "before vs after in one table"): per
# (sequence, noise) the mean over the trials (noise seeds) both hold, of fused ATE, registrations
# and the change metrics at the operating point (th_f, bound), then the mean over those cells.
# AFTER's runs made with --compare-free-space add the other rule on AFTER's own keyframes.
#   bash tools/repro/compare.sh BEFORE.json AFTER.json [TH_F=20] [BOUND=128] > table.md
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 BEFORE_RESULTS_JSON AFTER_RESULTS_JSON [TH_F=20] [BOUND=128]" >&2
  exit 2
fi
before=$1 after=$2 thf=${3:-20} bound=${4:-128}
for f in "$before" "$after"; do
  jq -e '.runs | type == "array"' "$f" >/dev/null 2>&1 ||
    { echo "compare: $f: expected a reproduce-paper results.json (with .runs)" >&2; exit 1; }
done
jq -r -n --slurpfile b "$before" --slurpfile a "$after" --argjson thf "$thf" --argjson bound "$bound" '
  def op: [.sweep[] | select(.th_f_m == $thf and .free_ray_bound_px == $bound)] | first;
  def rec: {key: "\(.sequence) \(.noise) \(.trial)", seq: .sequence, noise: .noise, trial: .trial,
            ate: .ate_fused.rmse, op: op, rule: .rule_compare,
            # A run detected again (--redetect) names the commits of its client and detector.
            commit: (if (.detect_commit // .commit) != .commit then "\(.commit) (detection \(.detect_commit))" else .commit end)};
  # Undefined values (R_rm of a run that observed no removed point) are left out of a mean.
  def mean(f): map(f) | map(select(. != null)) | if length == 0 then null else add / length end;
  def r3: if . == null then "–" else . * 1000 | round / 1000 end;
  def pair(x; y): "\(x | r3) → \(y | r3)";
  ($b[0].runs | map(rec) | map(select(.op != null)) | INDEX(.key)) as $B
  | [$a[0].runs[] | rec | select(.op != null and $B[.key] != null) | . + {before: $B[.key]}] as $both
  | ($both | group_by([.seq, .noise])) as $cells
  | ($both | map(.rule != null) | all) as $has_rule
  | ($both | map(.op.free_space // "paper") | unique | join(", ")) as $after_rule
  | ($both | map(.before.op.free_space // "paper") | unique | join(", ")) as $before_rule
  | "Operating point th_f \($thf) m, free-ray bound \($bound) px; mean over the trials both runs hold. Before: rule \($before_rule), commit(s) \($both | map(.before.commit) | unique | join(", ")); after: rule \($after_rule), commit(s) \($both | map(.commit) | unique | join(", "))." ,
    "",
    "| sequence | noise | trials | fused ATE (m) | R_new | P_new | R_rm | P_rm |" +
      (if $has_rule then " after, rule \($both[0].rule.free_space): R_rm | P_rm |" else "" end),
    "|---|---|---|---|---|---|---|---|" + (if $has_rule then "---|---|" else "" end),
    ($cells[] | . as $c |
      "| \($c[0].seq) | \($c[0].noise) | \($c | length) | \(pair($c | mean(.before.ate); $c | mean(.ate))) | " +
      ([ "R_new", "P_new", "R_rm", "P_rm" ] | map(. as $m | pair($c | mean(.before.op.paper[$m]); $c | mean(.op.paper[$m]))) | join(" | ")) + " |" +
      (if $has_rule then " \($c | mean(.rule.paper.R_rm) | r3) | \($c | mean(.rule.paper.P_rm) | r3) |" else "" end)),
    (if ($cells | length) > 1 then
      "| **mean of \($cells | length) cells** | | \($both | length) | " +
      ( [ "ate", "R_new", "P_new", "R_rm", "P_rm" ]
        | map(. as $m | ($cells | map(if $m == "ate" then mean(.before.ate) else mean(.before.op.paper[$m]) end) | mean(.)) as $x
                    | ($cells | map(if $m == "ate" then mean(.ate) else mean(.op.paper[$m]) end) | mean(.)) as $y
                    | "**" + pair($x; $y) + "**") | join(" | ")) + " |" +
      (if $has_rule then " \($cells | map(mean(.rule.paper.R_rm)) | mean(.) | r3) | \($cells | map(mean(.rule.paper.P_rm)) | mean(.) | r3) |" else "" end)
    else empty end)
'

// mapdelta-eval: ATE (as evo_ape) and the paper's change-detection metrics.
#include <nlohmann/json.hpp>

#include <fstream>
#include <iomanip>

#include "mapdelta/common/ate.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/metrics.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#include "mapdelta/tools/commands.hpp"

namespace mapdelta::tools {

const char* const kEvalUsage = R"(mapdelta-eval: trajectory and change-detection metrics.

usage:
  mapdelta-eval ate REF EST [--align se3|sim3|none] [--max-dt SECONDS] [--json FILE]
      Absolute trajectory error of EST against REF, as evo_ape.
  mapdelta-eval changes --original CLOUD --changed CLOUD --new CLOUD --removed CLOUD
                        --global CLOUD --observed OCTREE.bt [--th-ch M] [--rho-p M] [--json FILE]
      The paper's R_new, P_new, R_rm, P_rm and the reference-evaluation variant.
  mapdelta-eval removed-breakdown --original CLOUD --changed CLOUD --removed CLOUD --global CLOUD
                        --observed OCTREE.bt --keyframes DIR [--gt-depth DIR]
                        [--removed-at-gt-poses CLOUD] [--th-ch M] [--rho-p M] [--th-d M]
                        [--th-f M] [--free-ray-bound W] [--json FILE]
      Where the detected removed points come from (causes, range, view angle).
  mapdelta-eval COMMAND --help   a command's options

Exit codes: 0 success, 1 runtime failure or unreadable/malformed input, 2 usage or configuration error.
)";

namespace {

void WriteJson(const std::string& path, const nlohmann::json& json) {
  std::ofstream file(path);
  file << std::setw(2) << json << "\n";
  file.close();
  if (!file) throw Error(ErrorCode::kIo, path + ": cannot write JSON");
}

PointCloud ReadNonEmpty(const std::string& path, const char* what) {
  PointCloud cloud = ReadCloud(path);
  if (cloud.empty())
    throw Error(ErrorCode::kInvalidArgument, path + ": " + what + " cloud is empty");
  return cloud;
}

nlohmann::json MetricsJson(const ChangeMetrics& m) {
  return {{"R_new", m.recall_new},
          {"P_new", m.precision_new},
          {"R_rm", m.recall_removed},
          {"P_rm", m.precision_removed},
          {"counts",
           {{"gt_new", m.gt_new},
            {"gt_removed", m.gt_removed},
            {"gt_new_observed", m.gt_new_observed},
            {"gt_removed_observed", m.gt_removed_observed},
            {"gt_new_observed_tp", m.gt_new_observed_tp},
            {"gt_removed_observed_tp", m.gt_removed_observed_tp},
            {"detected_new", m.detected_new},
            {"detected_removed", m.detected_removed},
            {"detected_new_tp", m.detected_new_tp},
            {"detected_removed_tp", m.detected_removed_tp}}}};
}

}  // namespace

int RunEvalAte(const std::vector<std::string>& args, std::ostream& out) {
  AteParams params;
  std::string ref_path, est_path, align = "se3", json_path;
  cli::Parser cli(
      "mapdelta-eval ate",
      "Absolute trajectory error of EST against REF (TUM or EuRoC CSV, detected), as evo_ape:\n"
      "association within --max-dt, Umeyama alignment, translation errors: rmse mean median\n"
      "std min max sse and the number of pairs.");
  cli.Positional("REF", &ref_path, "reference trajectory")
      .Positional("EST", &est_path, "estimated trajectory")
      .Option("align", &align, "alignment before comparing")
      .Choices("align", {"se3", "sim3", "none"})
      .Option("max-dt", &params.max_dt_s, "association window [s]", "SECONDS")
      .Option("json", &json_path, "also write the figures as JSON", "FILE")
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, out)) return cli::kExitOk;
  ParseAteAlignment(align, &params.alignment);  // one of the choices above
  const Trajectory ref = ReadTrajectory(ref_path);
  const Trajectory est = ReadTrajectory(est_path);
  if (ref.empty()) throw Error(ErrorCode::kInvalidArgument, ref_path + ": trajectory has no poses");
  if (est.empty()) throw Error(ErrorCode::kInvalidArgument, est_path + ": trajectory has no poses");
  const AteResult r = ComputeAte(ref, est, params);
  out << std::setprecision(17) << "pairs  " << r.pairs << "\nrmse   " << r.rmse << "\nmean   "
      << r.mean << "\nmedian " << r.median << "\nstd    " << r.std << "\nmin    " << r.min
      << "\nmax    " << r.max << "\nsse    " << r.sse << "\n";
  if (params.alignment == AteAlignment::kSim3) out << "scale  " << r.alignment.scale << "\n";
  if (!json_path.empty()) {
    WriteJson(json_path, {{"reference", ref_path},
                          {"estimate", est_path},
                          {"align", align},
                          {"max_dt_s", params.max_dt_s},
                          {"pairs", r.pairs},
                          {"rmse", r.rmse},
                          {"mean", r.mean},
                          {"median", r.median},
                          {"std", r.std},
                          {"min", r.min},
                          {"max", r.max},
                          {"sse", r.sse},
                          {"scale", r.alignment.scale}});
  }
  return 0;
}

int RunEvalChanges(const std::vector<std::string>& args, std::ostream& out) {
  MetricsParams params;
  std::string paths[6], json_path;
  cli::Parser cli(
      "mapdelta-eval changes",
      "The paper's R_new, P_new, R_rm, P_rm (clouds .pcd/.ply) and beside them the\n"
      "reference-evaluation variant (radius outlier filter 4 m / 16 neighbours; removed ground\n"
      "truth observed through the octree only).");
  cli.Option("original", &paths[0], "original scene (ground truth before the change)", "CLOUD")
      .Option("changed", &paths[1], "changed scene (ground truth after)", "CLOUD")
      .Option("new", &paths[2], "detected new points", "CLOUD")
      .Option("removed", &paths[3], "detected removed points", "CLOUD")
      .Option("global", &paths[4], "the detector's global cloud P_g", "CLOUD")
      .Option("observed", &paths[5], "the detector's observed octree", "OCTREE.bt")
      .Option("th-ch", &params.th_ch_m, "change threshold th_ch [m]", "M")
      .Option("rho-p", &params.rho_p_m, "metric downsampling rho_p [m]", "M")
      .Option("json", &json_path, "also write the figures as JSON", "FILE")
      .Require({"original", "changed", "new", "removed", "global", "observed"})
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, out)) return cli::kExitOk;
  MD_LOG(kInfo, "loading clouds and the observed octree");
  const PointCloud original = ReadNonEmpty(paths[0], "original scene");
  const PointCloud changed = ReadNonEmpty(paths[1], "changed scene");
  const PointCloud detected_new = ReadCloud(paths[2]);
  const PointCloud detected_removed = ReadCloud(paths[3]);
  const PointCloud global = ReadNonEmpty(paths[4], "global");
  const ObservedArea observed = ObservedArea::Load(paths[5]);
  const MetricsInput input{original, changed, detected_new, detected_removed, global, observed};
  MD_LOG(kInfo, "computing the paper's metrics");
  const ChangeMetrics paper = EvaluateChangesPaper(input, params);
  MD_LOG(kInfo, "computing the reference-evaluation variant");
  const ChangeMetrics variant = EvaluateChangesReferenceVariant(input, params);
  out << std::setprecision(6) << std::fixed;
  for (const auto& [name, m] :
       {std::pair{"paper", &paper}, std::pair{"reference_variant", &variant}}) {
    out << name << ": R_new " << m->recall_new << "  P_new " << m->precision_new << "  R_rm "
        << m->recall_removed << "  P_rm " << m->precision_removed << "\n";
  }
  if (!json_path.empty()) {
    WriteJson(json_path, {{"th_ch_m", params.th_ch_m},
                          {"rho_p_m", params.rho_p_m},
                          {"paper", MetricsJson(paper)},
                          {"reference_variant", MetricsJson(variant)}});
  }
  return 0;
}

}  // namespace mapdelta::tools

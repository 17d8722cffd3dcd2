// mapdelta-eval: ATE (as evo_ape) and the paper's change-detection metrics.
#include <nlohmann/json.hpp>

#include <fstream>
#include <iomanip>

#include "mapdelta/common/ate.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/metrics.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#include "mapdelta/tools/cli_args.hpp"
#include "mapdelta/tools/commands.hpp"

namespace mapdelta::tools {

const char* const kEvalUsage = R"(usage:
  mapdelta-eval ate REF EST [--align se3|sim3|none] [--max-dt SECONDS] [--json FILE]
      Absolute trajectory error of EST against REF (TUM or EuRoC CSV, detected), as evo_ape:
      association within --max-dt (default 0.01 s), Umeyama alignment (default se3),
      translation errors: rmse mean median std min max sse and the number of pairs.
  mapdelta-eval changes --original CLOUD --changed CLOUD --new CLOUD --removed CLOUD
                        --global CLOUD --observed OCTREE.bt
                        [--th-ch M] [--rho-p M] [--json FILE]
      The paper's R_new, P_new, R_rm, P_rm (clouds .pcd/.ply; th_ch default 3.2 m, rho_p
      0.4 m), and beside them the reference-evaluation variant (radius outlier filter 4 m /
      16 neighbours; removed ground truth observed through the octree only).
  mapdelta-eval --help
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
  if (cloud.empty()) throw Error(ErrorCode::kInvalidArgument, path + ": " + what + " cloud is empty");
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
  const CliArgs cli(args, {"align", "max-dt", "json"}, {});
  if (cli.positionals().size() != 2) {
    throw Error(ErrorCode::kInvalidArgument, "ate needs exactly two trajectory files: REF EST");
  }
  AteParams params;
  if (!ParseAteAlignment(cli.Get("align", "se3"), &params.alignment)) {
    throw Error(ErrorCode::kInvalidArgument, "--align must be se3, sim3 or none");
  }
  params.max_dt_s = cli.GetDouble("max-dt", 0.01);
  const std::string& ref_path = cli.positionals()[0];
  const std::string& est_path = cli.positionals()[1];
  const Trajectory ref = ReadTrajectory(ref_path);
  const Trajectory est = ReadTrajectory(est_path);
  if (ref.empty()) throw Error(ErrorCode::kInvalidArgument, ref_path + ": trajectory has no poses");
  if (est.empty()) throw Error(ErrorCode::kInvalidArgument, est_path + ": trajectory has no poses");
  const AteResult r = ComputeAte(ref, est, params);
  out << std::setprecision(17) << "pairs  " << r.pairs << "\nrmse   " << r.rmse << "\nmean   "
      << r.mean << "\nmedian " << r.median << "\nstd    " << r.std << "\nmin    " << r.min
      << "\nmax    " << r.max << "\nsse    " << r.sse << "\n";
  if (params.alignment == AteAlignment::kSim3) out << "scale  " << r.alignment.scale << "\n";
  if (cli.Has("json")) {
    WriteJson(cli.Get("json", ""),
              {{"reference", ref_path}, {"estimate", est_path}, {"align", cli.Get("align", "se3")},
               {"max_dt_s", params.max_dt_s}, {"pairs", r.pairs}, {"rmse", r.rmse}, {"mean", r.mean},
               {"median", r.median}, {"std", r.std}, {"min", r.min}, {"max", r.max}, {"sse", r.sse},
               {"scale", r.alignment.scale}});
  }
  return 0;
}

int RunEvalChanges(const std::vector<std::string>& args, std::ostream& out) {
  const CliArgs cli(args, {"original", "changed", "new", "removed", "global", "observed", "th-ch",
                           "rho-p", "json"},
                    {});
  if (!cli.positionals().empty()) {
    throw Error(ErrorCode::kInvalidArgument, "changes takes no positional arguments (got '" +
                                                 cli.positionals()[0] + "')");
  }
  MetricsParams params;
  params.th_ch_m = cli.GetDouble("th-ch", params.th_ch_m);
  params.rho_p_m = cli.GetDouble("rho-p", params.rho_p_m);
  // Check every option before the slow loading starts.
  const std::string paths[] = {cli.Require("original"), cli.Require("changed"), cli.Require("new"),
                               cli.Require("removed"),  cli.Require("global"),  cli.Require("observed")};
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
  for (const auto& [name, m] : {std::pair{"paper", &paper}, std::pair{"reference_variant", &variant}}) {
    out << name << ": R_new " << m->recall_new << "  P_new " << m->precision_new << "  R_rm "
        << m->recall_removed << "  P_rm " << m->precision_removed << "\n";
  }
  if (cli.Has("json")) {
    WriteJson(cli.Get("json", ""), {{"th_ch_m", params.th_ch_m},
                                    {"rho_p_m", params.rho_p_m},
                                    {"paper", MetricsJson(paper)},
                                    {"reference_variant", MetricsJson(variant)}});
  }
  return 0;
}

}  // namespace mapdelta::tools

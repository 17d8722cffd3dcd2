// mapdelta-eval removed-breakdown: the explanation of a detector run's removed points
// (removed_breakdown.hpp) as Markdown tables on stdout and optionally JSON.
#include <nlohmann/json.hpp>

#include <fstream>
#include <iomanip>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/tools/commands.hpp"
#include "mapdelta/tools/removed_breakdown.hpp"

namespace mapdelta::tools {
namespace {

void PrintTable(const BreakdownTable& t, size_t false_total, std::ostream& out) {
  out << "| " << t.attribute
      << " | false removed | share of false | true removed |\n|---|---|---|---|\n";
  for (size_t b = 0; b < t.bins.size(); ++b) {
    const double share = false_total ? static_cast<double>(t.false_count[b]) / false_total : 0.0;
    out << "| " << t.bins[b] << " | " << t.false_count[b] << " | " << std::fixed
        << std::setprecision(3) << share << " | " << t.true_count[b] << " |\n";
  }
  out << "\n";
}

nlohmann::json TablesJson(const RemovedBreakdown& b) {
  nlohmann::json tables = nlohmann::json::object();
  for (const auto& t : b.tables) {
    nlohmann::json rows = nlohmann::json::array();
    for (size_t i = 0; i < t.bins.size(); ++i) {
      rows.push_back({{"bin", t.bins[i]}, {"false", t.false_count[i]}, {"true", t.true_count[i]}});
    }
    tables[t.attribute] = rows;
  }
  return {
      {"detected_removed", b.detected}, {"false_removed", b.false_positives}, {"tables", tables}};
}

}  // namespace

int RunEvalRemovedBreakdown(const std::vector<std::string>& args, std::ostream& out) {
  RemovedBreakdownParams params;
  std::string paths[6], gt_depth_dir, at_gt_path, json_path;
  cli::Parser cli(
      "mapdelta-eval removed-breakdown",
      "Where a detector run's removed points come from: each labelled true/false as the paper's\n"
      "metric does, then explained by the keyframe rays through its pixel (stereo depth beyond\n"
      "it, or no depth; hidden behind other geometry and stereo overshoot from the ground-truth\n"
      "depth; gone in a run at ground-truth poses). Tables by cause, range, view angle.");
  cli.Option("original", &paths[0], "original scene (ground truth before the change)", "CLOUD")
      .Option("changed", &paths[1], "changed scene (ground truth after)", "CLOUD")
      .Option("removed", &paths[2], "the detector's removed points", "CLOUD")
      .Option("global", &paths[3], "the detector's global cloud P_g", "CLOUD")
      .Option("observed", &paths[4], "the detector's observed octree", "OCTREE.bt")
      .Option("keyframes", &paths[5], "the keyframe folder the detector ran on", "DIR")
      .Option("gt-depth", &gt_depth_dir,
              "the sequence's ground-truth depth (SEQ/mav0/depth0/data): hidden and overshoot",
              "DIR")
      .Option("removed-at-gt-poses", &at_gt_path,
              "removed points of a run on the same depth at ground-truth poses: pose error",
              "CLOUD")
      .Option("th-ch", &params.th_ch_m, "change threshold th_ch of the metric [m]", "M")
      .Option("rho-p", &params.rho_p_m, "metric downsampling rho_p [m]", "M")
      .Option("th-d", &params.max_depth_m, "max depth th_d the detector ran with [m]", "M")
      .Option("th-f", &params.free_ray_m, "free-ray depth th_f the detector ran with [m]", "M")
      .Option("free-ray-bound", &params.free_ray_bound_px,
              "free-ray bound the detector ran with [px]", "W")
      .Option("json", &json_path, "also write the tables as JSON", "FILE")
      .Require({"original", "changed", "removed", "global", "observed", "keyframes"})
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, out)) return cli::kExitOk;
  if (params.free_ray_bound_px < 0)
    cli::FailUsage(cli.program(), "--free-ray-bound: expected >= 0, got " +
                                      std::to_string(params.free_ray_bound_px));
  MD_LOG(kInfo, "loading clouds and the observed octree");
  const PointCloud original = ReadCloud(paths[0]), changed = ReadCloud(paths[1]);
  const PointCloud removed = ReadCloud(paths[2]), global = ReadCloud(paths[3]);
  const ObservedArea observed = ObservedArea::Load(paths[4]);
  std::optional<PointCloud> at_gt;
  if (!at_gt_path.empty()) at_gt = ReadCloud(at_gt_path);
  const RemovedBreakdownInput input{original, changed,  removed,      global,
                                    observed, paths[5], gt_depth_dir, at_gt ? &*at_gt : nullptr};
  const RemovedBreakdown b = BreakDownRemoved(input, params);
  out << "detected removed " << b.detected << " (at rho_p " << params.rho_p_m << " m), false "
      << b.false_positives << "\n\n";
  for (const auto& t : b.tables) PrintTable(t, b.false_positives, out);
  if (!json_path.empty()) {
    const std::string& path = json_path;
    std::ofstream file(path);
    file << std::setw(2) << TablesJson(b) << "\n";
    file.close();
    if (!file) throw Error(ErrorCode::kIo, path + ": cannot write JSON");
  }
  return 0;
}

}  // namespace mapdelta::tools

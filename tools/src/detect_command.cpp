// mapdelta-detect: the paper's change-detection pipeline offline, from a prior cloud and a
// keyframe folder to the global cloud, the observed octree and the new / removed clouds.
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/tools/commands.hpp"

namespace mapdelta::tools {

const char* const kDetectDescription =
    "Runs the paper's change detection: global cloud from the keyframes (TUM poses T_map_cam +\n"
    "16-bit depth, see docs/conventions.md), optional GICP alignment to the prior, observed area\n"
    "(OctoMap), observed prior cloud (Alg. 1) and new/removed classification (Alg. 2). Writes\n"
    "OUT/global.pcd, OUT/observed.bt, OUT/new.pcd, OUT/removed.pcd (or .ply / .las with "
    "--format),\n"
    "OUT/summary.json.\n"
    "Paper names, defaults from DESIGN.md.";

namespace {

AlignFunction GicpAlignment() {
  return [](const PointCloud& prior, const PointCloud& global) {
    GicpParams params;
    params.voxel_m = 0.8;
    const RegistrationResult r = AlignGicp(prior, global, SE3::Identity(), params);
    if (!r.converged) {
      MD_LOG(kWarn, "GICP alignment did not converge after " << r.iterations
                                                             << " iterations; keeping the poses as they are");
      return SE3(SE3::Identity());
    }
    MD_LOG(kInfo, "GICP alignment: fitness " << r.fitness_m << " m, " << r.num_inliers << "/"
                                             << r.num_source_points << " inliers, translation "
                                             << r.T_target_source.translation().transpose());
    return r.T_target_source;
  };
}

}  // namespace

int RunDetect(const std::vector<std::string>& args, std::ostream& out) {
  ChangeDetectionParams params;
  std::string prior_path, keyframe_dir, out_dir, align = "none", format = "pcd";
  cli::Parser cli("mapdelta-detect", kDetectDescription);
  cli.Option("prior", &prior_path, "prior map cloud (.pcd/.ply/.las)", "CLOUD")
      .Option("keyframes", &keyframe_dir, "keyframe folder (camera.yaml, poses.txt, depth/)", "DIR")
      .Option("out", &out_dir, "output folder", "DIR")
      .Option("th-ch", &params.th_ch_m, "change threshold th_ch [m]", "M")
      .Option("th-d", &params.observed.max_depth_m,
              "max depth th_d for the global cloud and hit rays [m]", "M")
      .Option("th-f", &params.observed.free_ray_m,
              "free-space ray depth th_f for pixels without depth [m]", "M")
      .Option("free-ray-bound", &params.observed.free_ray_bound_window_px,
              "end each no-depth free ray at the nearest valid depth within +-W pixels "
              "(0 = the paper's rule: always th_f)",
              "W")
      .Option("rho-o", &params.observed.resolution_m, "octree resolution rho_o [m]", "M")
      .Option("voxel", &params.cloud_voxel_m, "cloud downsampling before comparing [m]", "M")
      .Option("stride", &params.observed.pixel_stride, "use every N-th pixel for ray casting")
      .Option("align", &align, "align the global cloud to the prior first")
      .Choices("align", {"none", "gicp"})
      .Option("format", &format, "file format of the written clouds (global, new, removed)")
      .Choices("format", {"pcd", "ply", "las"})
      .Require({"prior", "keyframes", "out"})
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, out)) return cli::kExitOk;
  params.observed.prefilter_voxel_m = params.observed.resolution_m;

  const auto start = std::chrono::steady_clock::now();
  MD_LOG(kInfo, "reading prior " << prior_path);
  const PointCloud prior = ReadCloud(prior_path);
  if (prior.empty()) throw Error(ErrorCode::kInvalidArgument, prior_path + ": prior cloud is empty");
  MD_LOG(kInfo, "reading keyframes from " << keyframe_dir);
  // Poses only here; depth images are streamed from disk by the pipeline.
  const KeyframeFolder keyframes = ReadKeyframeFolderIndex(keyframe_dir);
  if (keyframes.keyframes.empty()) {
    throw Error(ErrorCode::kInvalidArgument, keyframe_dir + "/poses.txt: no keyframes listed");
  }
  std::filesystem::create_directories(out_dir);
  int last_percent = -1;
  std::string last_stage;
  const auto progress = [&](const std::string& stage, double fraction) {
    const int percent = static_cast<int>(fraction * 100);
    if (stage != last_stage || percent / 10 != last_percent / 10) {
      MD_LOG(kInfo, stage << " " << percent << "%");
      last_stage = stage;
      last_percent = percent;
    }
  };
  const ChangeDetectionResult result = DetectChangesInFolder(
      keyframe_dir, prior, params, align == "gicp" ? GicpAlignment() : AlignFunction(), progress);
  MD_LOG(kInfo, "writing results to " << out_dir);
  WriteCloud(out_dir + "/global." + format, result.global);
  result.observed.Save(out_dir + "/observed.bt");
  WriteCloud(out_dir + "/new." + format, result.changes.new_points);
  WriteCloud(out_dir + "/removed." + format, result.changes.removed_points);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::vector<double> T_row_major;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) T_row_major.push_back(result.T_prior_global.matrix()(r, c));
  nlohmann::json summary = {
      {"prior", prior_path}, {"keyframes", keyframes.keyframes.size()},
      {"th_ch_m", params.th_ch_m}, {"th_d_m", params.observed.max_depth_m},
      {"th_f_m", params.observed.free_ray_m},
      {"free_ray_bound_window_px", params.observed.free_ray_bound_window_px}, {"rho_o_m", params.observed.resolution_m},
      {"cloud_voxel_m", params.cloud_voxel_m}, {"align", align},
      {"T_prior_global", T_row_major},
      {"global_points", result.global.size()}, {"observed_prior_points", result.observed_prior.size()},
      {"new_points", result.changes.new_points.size()},
      {"removed_points", result.changes.removed_points.size()}, {"seconds", seconds}};
  std::ofstream(out_dir + "/summary.json") << std::setw(2) << summary << "\n";
  out << "global " << result.global.size() << " points, observed prior " << result.observed_prior.size()
      << ", new " << result.changes.new_points.size() << ", removed "
      << result.changes.removed_points.size() << " (" << std::fixed << std::setprecision(1) << seconds
      << " s)\n";
  return 0;
}

}  // namespace mapdelta::tools

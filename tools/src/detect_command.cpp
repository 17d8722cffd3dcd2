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
    "Paper names, defaults from docs/design.md.";

namespace {

AlignFunction GicpAlignment() {
  return [](const PointCloud& prior, const PointCloud& global) {
    GicpParams params;
    params.voxel_m = 0.8;
    const RegistrationResult r = AlignGicp(prior, global, SE3::Identity(), params);
    if (!r.converged) {
      MD_LOG(kWarn, "GICP alignment did not converge after "
                        << r.iterations << " iterations; keeping the poses as they are");
      return SE3(SE3::Identity());
    }
    MD_LOG(kInfo, "GICP alignment: fitness " << r.fitness_m << " m, " << r.num_inliers << "/"
                                             << r.num_source_points << " inliers, translation "
                                             << r.T_target_source.translation().transpose());
    return r.T_target_source;
  };
}

// What the command line sets: the detector's parameters and the files.
struct DetectOptions {
  ChangeDetectionParams params;
  std::string prior_path, keyframe_dir, out_dir, align = "none", format = "pcd";
  std::string free_space = "confident";
};

// Parses the command line into `o`; false when --help was asked for. The free-space rule is
// applied first and the ablation options then override single parts of it.
bool ParseDetectOptions(const std::vector<std::string>& args, std::ostream& out, DetectOptions* o) {
  ChangeDetectionParams& params = o->params;
  double sigma_per_m2 = 0, footprint_radius = 0, mask_radius = 0, mask_weak_radius = 0;
  int stop_at_prior = 0, min_free_keyframes = 0, new_not_seen_free = 0, mask_min_keyframes = 0;
  cli::Parser cli("mapdelta-detect", kDetectDescription);
  cli.Option("prior", &o->prior_path, "prior map cloud (.pcd/.ply/.las)", "CLOUD")
      .Option("keyframes", &o->keyframe_dir, "keyframe folder (camera.yaml, poses.txt, depth/)",
              "DIR")
      .Option("out", &o->out_dir, "output folder", "DIR")
      .Option("th-ch", &params.th_ch_m, "change threshold th_ch [m]", "M")
      .Option("th-d", &params.observed.max_depth_m,
              "max depth th_d for the global cloud and hit rays [m]", "M")
      .Option("th-f", &params.observed.free_ray_m,
              "free-space ray depth th_f for pixels without depth [m]", "M")
      .Option("free-ray-bound", &params.observed.free_ray_bound_window_px,
              "end each no-depth free ray at the nearest valid depth within +-W pixels "
              "(0 = the paper's rule: always th_f)",
              "W")
      .Option("free-space", &o->free_space,
              "the rule for the free space behind removed points: confident = a removed "
              "point's voxel seen free by 3 keyframes, hit rays end 3 sigma(d) before the hit "
              "(change_detection.hpp); paper = Alg. 1-2 as published",
              "RULE")
      .Choices("free-space", {"paper", "confident"})
      .Option("depth-sigma-per-m2", &sigma_per_m2,
              "ablation: override the rule's depth uncertainty sigma = C d^2 (0 = off)", "C")
      .Option("stop-at-prior", &stop_at_prior,
              "ablation: override whether rays without depth stop at the prior's surfaces "
              "(0 or 1)",
              "0|1")
      .Option("removed-min-free-keyframes", &min_free_keyframes,
              "ablation: override how many keyframes must see a removed point's voxel free "
              "(0 = any known voxel)")
      .Option("removed-mask-radius", &mask_radius,
              "ablation: override how near a prior point a global point must be to mask the "
              "removals within th_ch of it [m] (0 = every global point masks)",
              "M")
      .Option("mask-min-keyframes", &mask_min_keyframes,
              "ablation: a global point masks removals only when this many keyframes put a "
              "point in its voxel (0 = off)")
      .Option("mask-weak-radius", &mask_weak_radius,
              "ablation: a global point under --mask-min-keyframes still masks within this "
              "distance of a prior point [m] (0 = never)",
              "M")
      .Option("footprint-radius", &footprint_radius,
              "ablation: override how far (horizontally) from the prior a new point may lie "
              "[m] (0 = anywhere)",
              "M")
      .Option("new-not-seen-free", &new_not_seen_free,
              "ablation: override whether a new point's voxel must not be seen free net of "
              "hits (0 or 1)",
              "0|1")
      .Option("rho-o", &params.observed.resolution_m, "octree resolution rho_o [m]", "M")
      .Option("voxel", &params.cloud_voxel_m, "cloud downsampling before comparing [m]", "M")
      .Option("stride", &params.observed.pixel_stride, "use every N-th pixel for ray casting")
      .Option("align", &o->align, "align the global cloud to the prior first")
      .Choices("align", {"none", "gicp"})
      .Option("format", &o->format, "file format of the written clouds (global, new, removed)")
      .Choices("format", {"pcd", "ply", "las"})
      .Require({"prior", "keyframes", "out"})
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, out)) return false;
  params.observed.prefilter_voxel_m = params.observed.resolution_m;
  ApplyFreeSpaceRule(o->free_space, &params);
  if (cli.Given("depth-sigma-per-m2")) params.observed.depth_sigma_per_m2 = sigma_per_m2;
  const auto flag = [&](const char* name, int value) {
    if (value != 0 && value != 1)
      cli::FailUsage("mapdelta-detect",
                     std::string("--") + name + ": expected 0 or 1, got " + std::to_string(value));
    return value == 1;
  };
  if (cli.Given("stop-at-prior"))
    params.free_rays_stop_at_prior = flag("stop-at-prior", stop_at_prior);
  if (cli.Given("new-not-seen-free"))
    params.new_not_seen_free = flag("new-not-seen-free", new_not_seen_free);
  if (cli.Given("removed-min-free-keyframes"))
    params.removed_min_free_keyframes = min_free_keyframes;
  if (cli.Given("footprint-radius")) params.new_footprint_radius_m = footprint_radius;
  if (cli.Given("removed-mask-radius")) params.removed_mask_radius_m = mask_radius;
  if (cli.Given("mask-min-keyframes")) params.mask_min_keyframes = mask_min_keyframes;
  if (cli.Given("mask-weak-radius")) params.mask_weak_radius_m = mask_weak_radius;
  return true;
}

}  // namespace

int RunDetect(const std::vector<std::string>& args, std::ostream& out) {
  DetectOptions options;
  if (!ParseDetectOptions(args, out, &options)) return cli::kExitOk;
  const ChangeDetectionParams& params = options.params;
  const std::string &prior_path = options.prior_path, &keyframe_dir = options.keyframe_dir;
  const std::string &out_dir = options.out_dir, &align = options.align, &format = options.format;

  const auto start = std::chrono::steady_clock::now();
  MD_LOG(kInfo, "reading prior " << prior_path);
  const PointCloud prior = ReadCloud(prior_path);
  if (prior.empty())
    throw Error(ErrorCode::kInvalidArgument, prior_path + ": prior cloud is empty");
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
  nlohmann::json summary = {{"prior", prior_path},
                            {"keyframes", keyframes.keyframes.size()},
                            {"th_ch_m", params.th_ch_m},
                            {"th_d_m", params.observed.max_depth_m},
                            {"th_f_m", params.observed.free_ray_m},
                            {"free_ray_bound_window_px", params.observed.free_ray_bound_window_px},
                            {"free_space", options.free_space},
                            {"depth_sigma_per_m2", params.observed.depth_sigma_per_m2},
                            {"free_rays_stop_at_prior", params.free_rays_stop_at_prior},
                            {"removed_min_free_keyframes", params.removed_min_free_keyframes},
                            {"new_footprint_radius_m", params.new_footprint_radius_m},
                            {"new_not_seen_free", params.new_not_seen_free},
                            {"removed_mask_radius_m", params.removed_mask_radius_m},
                            {"mask_min_keyframes", params.mask_min_keyframes},
                            {"mask_weak_radius_m", params.mask_weak_radius_m},
                            {"rho_o_m", params.observed.resolution_m},
                            {"cloud_voxel_m", params.cloud_voxel_m},
                            {"align", align},
                            {"T_prior_global", T_row_major},
                            {"global_points", result.global.size()},
                            {"observed_prior_points", result.observed_prior.size()},
                            {"new_points", result.changes.new_points.size()},
                            {"removed_points", result.changes.removed_points.size()},
                            {"seconds", seconds}};
  std::ofstream(out_dir + "/summary.json") << std::setw(2) << summary << "\n";
  out << "global " << result.global.size() << " points, observed prior "
      << result.observed_prior.size() << ", new " << result.changes.new_points.size()
      << ", removed " << result.changes.removed_points.size() << " (" << std::fixed
      << std::setprecision(1) << seconds << " s)\n";
  return 0;
}

}  // namespace mapdelta::tools

// mapdelta-client depth-eval: a keyframe folder's filtered depth against the sequence's
// ground-truth depth (depth0, same timestamps): RMSE, density, share of > 1 m errors. Used to
// choose the temporal filter's alpha on simulated sequences (client/README.md).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>

#include "commands.hpp"
#include "mapdelta/client/stereo_depth.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/keyframes.hpp"

namespace mapdelta::client::app {

int RunDepthEval(int argc, char** argv) {
  std::string keyframe_dir, sequence_dir;
  double max_depth = 50;
  cli::Parser cli(
      "mapdelta-client depth-eval",
      "Compares every keyframe's depth with the sequence's depth0 image of the same time (cropped\n"
      "like the keyframe camera). Prints RMSE, density (share of ground-truth pixels with a "
      "depth)\n"
      "and the share of depths off by more than 1 m, over all keyframes.");
  cli.Positional("KEYFRAMES_DIR", &keyframe_dir, "keyframe folder")
      .Positional("SEQUENCE_DIR", &sequence_dir, "EuRoC-layout sequence with depth0 ground truth")
      .Option("max-depth", &max_depth, "ground truth beyond this is ignored [m]", "M")
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(argc, argv, std::cout)) return cli::kExitOk;
  const KeyframeFolder folder = ReadKeyframeFolderIndex(keyframe_dir);
  const EurocSequence seq = ReadEurocSequence(sequence_dir);
  if (seq.depth0_images.empty())
    throw Error(ErrorCode::kNotFound, sequence_dir + ": no depth0 ground truth");
  std::map<int64_t, std::string> gt_path;
  for (const auto& im : seq.depth0_images) gt_path[im.t_ns] = im.path;
  double sq = 0;
  size_t n = 0, gt_n = 0, bad = 0, keyframes = 0;
  for (const auto& kf : folder.keyframes) {
    const auto it = gt_path.find(kf.t_ns);
    if (it == gt_path.end()) continue;
    const DepthImage est = ReadKeyframeDepth(keyframe_dir, folder, kf.t_ns);
    DepthImage gt = ReadDepthPng(it->second);
    if (gt.width < est.width || gt.height != est.height) {
      throw Error(ErrorCode::kInvalidArgument,
                  it->second + ": size does not match the keyframe depth");
    }
    gt = CropLeftBand(gt, gt.width - est.width);
    ++keyframes;
    for (size_t k = 0; k < gt.depth_m.size(); ++k) {
      if (!(gt.depth_m[k] > 0.f) || gt.depth_m[k] > max_depth) continue;
      ++gt_n;
      if (!(est.depth_m[k] > 0.f)) continue;
      const double e = est.depth_m[k] - gt.depth_m[k];
      sq += e * e;
      bad += std::abs(e) > 1.0;
      ++n;
    }
  }
  if (keyframes == 0)
    throw Error(ErrorCode::kNotFound, "no keyframe has a depth0 image of the same time");
  std::printf("%zu keyframes: RMSE %.3f m, density %.3f, >1 m errors %.4f (%zu depths)\n",
              keyframes, std::sqrt(sq / std::max<size_t>(n, 1)),
              static_cast<double>(n) / std::max<size_t>(gt_n, 1),
              static_cast<double>(bad) / std::max<size_t>(n, 1), n);
  return 0;
}

}  // namespace mapdelta::client::app

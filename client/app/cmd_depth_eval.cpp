// mapdelta-client depth-eval: a keyframe folder's filtered depth against the sequence's
// ground-truth depth (depth0, same timestamps): RMSE, density, share of > 1 m errors. Used to
// choose the temporal filter's alpha on simulated sequences (client/README.md).
#include <cmath>
#include <cstdio>
#include <map>

#include "args.hpp"
#include "commands.hpp"
#include "mapdelta/client/stereo_depth.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/keyframes.hpp"

namespace mapdelta::client::app {

int RunDepthEval(int argc, char** argv) {
  const char* usage =
      "usage: mapdelta-client depth-eval KEYFRAMES_DIR SEQUENCE_DIR [--max-depth M]\n"
      "  compares every keyframe's depth with the sequence's depth0 image of the same time\n"
      "  (cropped like the keyframe camera); ground truth beyond --max-depth (default 50 m) is\n"
      "  ignored. Prints RMSE, density (share of ground-truth pixels with a depth) and the share\n"
      "  of depths off by more than 1 m, over all keyframes.\n";
  Args args;
  try {
    args = ParseArgs(argc, argv, {"max-depth"}, {});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n%s", e.what(), usage);
    return 2;
  }
  if (args.help) {
    std::fprintf(stderr, "%s", usage);
    return 0;
  }
  if (args.positional.size() != 2) {
    std::fprintf(stderr, "%s", usage);
    return 2;
  }
  const double max_depth = std::stod(args.Get("max-depth", "50"));
  const KeyframeFolder folder = ReadKeyframeFolderIndex(args.positional[0]);
  const EurocSequence seq = ReadEurocSequence(args.positional[1]);
  if (seq.depth0_images.empty()) throw Error(ErrorCode::kNotFound, args.positional[1] + ": no depth0 ground truth");
  std::map<int64_t, std::string> gt_path;
  for (const auto& im : seq.depth0_images) gt_path[im.t_ns] = im.path;
  double sq = 0;
  size_t n = 0, gt_n = 0, bad = 0, keyframes = 0;
  for (const auto& kf : folder.keyframes) {
    const auto it = gt_path.find(kf.t_ns);
    if (it == gt_path.end()) continue;
    const DepthImage est = ReadKeyframeDepth(args.positional[0], folder, kf.t_ns);
    DepthImage gt = ReadDepthPng(it->second);
    if (gt.width < est.width || gt.height != est.height) {
      throw Error(ErrorCode::kInvalidArgument, it->second + ": size does not match the keyframe depth");
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
  if (keyframes == 0) throw Error(ErrorCode::kNotFound, "no keyframe has a depth0 image of the same time");
  std::printf("%zu keyframes: RMSE %.3f m, density %.3f, >1 m errors %.4f (%zu depths)\n", keyframes,
              std::sqrt(sq / std::max<size_t>(n, 1)), static_cast<double>(n) / std::max<size_t>(gt_n, 1),
              static_cast<double>(bad) / std::max<size_t>(n, 1), n);
  return 0;
}

}  // namespace mapdelta::client::app

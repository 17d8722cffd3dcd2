#include "mapdelta/client/temporal_filter.hpp"

#include <cmath>
#include <limits>

#include "mapdelta/common/error.hpp"

namespace mapdelta::client {

DepthImage TemporalFilter(const std::vector<DepthFrame>& frames, size_t center,
                          const PinholeCamera& camera, const TemporalFilterConfig& config,
                          TemporalFilterStats* stats) {
  if (center >= frames.size() || frames[center].depth == nullptr) {
    throw Error(ErrorCode::kInvalidArgument, "temporal filter: center frame missing");
  }
  const DepthImage& di = *frames[center].depth;
  if (di.width != camera.width || di.height != camera.height) {
    throw Error(ErrorCode::kInvalidArgument, "temporal filter: depth size differs from camera");
  }
  const size_t n = di.depth_m.size();
  std::vector<int> successes(n, 0);
  std::vector<float> sums(n, 0.f);
  // Per neighbour: the projected depth closest to d_i at each pixel, so several source pixels
  // landing on one target pixel count as one success of that neighbour.
  std::vector<float> best(n);
  int neighbours = 0;
  const SE3 T_cami_world = frames[center].T_world_cam.inverse();

  for (size_t j = 0; j < frames.size(); ++j) {
    if (j == center || frames[j].depth == nullptr) continue;
    const DepthImage& dj = *frames[j].depth;
    if (dj.width != di.width || dj.height != di.height) {
      throw Error(ErrorCode::kInvalidArgument, "temporal filter: neighbour depth size differs");
    }
    ++neighbours;
    std::fill(best.begin(), best.end(), std::numeric_limits<float>::quiet_NaN());
    const SE3 T_cami_camj = T_cami_world * frames[j].T_world_cam;
    const Eigen::Matrix3d R = T_cami_camj.linear();
    const Eigen::Vector3d t = T_cami_camj.translation();
    for (int v = 0; v < dj.height; ++v) {
      for (int u = 0; u < dj.width; ++u) {
        const float z = dj.at(u, v);
        if (!(z > 0.f)) continue;
        // 1. back-project pixel of j, 2. move into i, 3. project and round to a pixel.
        const Eigen::Vector3d p_i = R * camera.BackProject(u, v, z) + t;
        if (p_i.z() <= 1e-6) continue;
        const double ui = camera.fx * p_i.x() / p_i.z() + camera.cx;
        const double vi = camera.fy * p_i.y() / p_i.z() + camera.cy;
        const int iu = static_cast<int>(std::lround(ui));
        const int iv = static_cast<int>(std::lround(vi));
        if (iu < 0 || iv < 0 || iu >= di.width || iv >= di.height) continue;
        const size_t k = static_cast<size_t>(iv) * di.width + iu;
        const float d_here = di.depth_m[k];
        if (!(d_here > 0.f)) continue;
        const float projected = static_cast<float>(p_i.z());
        // 4. success test against the current frame's depth at the hit pixel.
        if (std::abs(projected - d_here) >= config.delta_d_m) continue;
        if (std::isnan(best[k]) || std::abs(projected - d_here) < std::abs(best[k] - d_here)) {
          best[k] = projected;
        }
      }
    }
    for (size_t k = 0; k < n; ++k) {
      if (!std::isnan(best[k])) {
        ++successes[k];
        sums[k] += best[k];
      }
    }
  }

  const int alpha = std::min(config.alpha, neighbours);
  DepthImage out(di.width, di.height);
  size_t in_valid = 0;
  for (size_t k = 0; k < n; ++k) {
    const float d = di.depth_m[k];
    if (!(d > 0.f)) continue;
    ++in_valid;
    if (successes[k] >= alpha) out.depth_m[k] = (d + sums[k]) / static_cast<float>(successes[k] + 1);
  }
  if (stats != nullptr) {
    stats->input_valid = in_valid;
    stats->output_valid = out.CountValid();
  }
  return out;
}

}  // namespace mapdelta::client

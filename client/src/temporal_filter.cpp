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
  int neighbours = 0;
  const SE3 T_world_cami = frames[center].T_world_cam;
  for (size_t j = 0; j < frames.size(); ++j) {
    if (j == center || frames[j].depth == nullptr) continue;
    const DepthImage& dj = *frames[j].depth;
    if (dj.width != di.width || dj.height != di.height) {
      throw Error(ErrorCode::kInvalidArgument, "temporal filter: neighbour depth size differs");
    }
    ++neighbours;
    const SE3 T_camj_cami = frames[j].T_world_cam.inverse() * T_world_cami;
    const SE3 T_cami_camj = T_camj_cami.inverse();
    for (int v = 0; v < di.height; ++v) {
      for (int u = 0; u < di.width; ++u) {
        const size_t k = static_cast<size_t>(v) * di.width + u;
        const float d_here = di.depth_m[k];
        if (!(d_here > 0.f)) continue;
        // 1. Find the pixel of j that sees this pixel's point (nearest pixel).
        const Eigen::Vector3d p_j = T_camj_cami * camera.BackProject(u, v, d_here);
        if (p_j.z() <= 1e-6) continue;
        const long uj = std::lround(camera.fx * p_j.x() / p_j.z() + camera.cx);
        const long vj = std::lround(camera.fy * p_j.y() / p_j.z() + camera.cy);
        if (uj < 0 || vj < 0 || uj >= dj.width || vj >= dj.height) continue;
        const float zj = dj.at(static_cast<int>(uj), static_cast<int>(vj));
        if (!(zj > 0.f)) continue;
        // 2. Re-project j's depth there into i: the projected depth d_j^i.
        const double projected =
            (T_cami_camj * camera.BackProject(static_cast<double>(uj), static_cast<double>(vj), zj)).z();
        // 3. Success test against the current frame's depth.
        if (std::abs(projected - d_here) >= config.delta_d_m) continue;
        ++successes[k];
        sums[k] += static_cast<float>(projected);
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

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
  // Normalized image coordinates of every column and row, so that back-projecting a pixel is
  // two multiplications (camera.BackProject divides per call; the filter does that twice per
  // pixel and neighbour: it ran at 90 ms per 800x450 keyframe in the paper-preset client).
  std::vector<double> x_of_u(static_cast<size_t>(di.width)), y_of_v(static_cast<size_t>(di.height));
  for (int u = 0; u < di.width; ++u) x_of_u[static_cast<size_t>(u)] = (u - camera.cx) / camera.fx;
  for (int v = 0; v < di.height; ++v) y_of_v[static_cast<size_t>(v)] = (v - camera.cy) / camera.fy;
  // std::lround without the library call: half away from zero.
  const auto nearest_pixel = [](double x) { return static_cast<long>(x >= 0 ? x + 0.5 : x - 0.5); };
  for (size_t j = 0; j < frames.size(); ++j) {
    if (j == center || frames[j].depth == nullptr) continue;
    const DepthImage& dj = *frames[j].depth;
    if (dj.width != di.width || dj.height != di.height) {
      throw Error(ErrorCode::kInvalidArgument, "temporal filter: neighbour depth size differs");
    }
    ++neighbours;
    const SE3 T_camj_cami = frames[j].T_world_cam.inverse() * T_world_cami;
    const Eigen::Matrix3d R_ji = T_camj_cami.linear();
    const Eigen::Vector3d t_ji = T_camj_cami.translation();
    // Only the depth (z) of j's point seen from i is needed: the last row of T_cami_camj.
    const SE3 T_cami_camj = T_camj_cami.inverse();
    const Eigen::Vector3d z_row_ij = T_cami_camj.linear().row(2).transpose();
    const double z_t_ij = T_cami_camj.translation().z();
    for (int v = 0; v < di.height; ++v) {
      const double y = y_of_v[static_cast<size_t>(v)];
      for (int u = 0; u < di.width; ++u) {
        const size_t k = static_cast<size_t>(v) * di.width + u;
        const float d_here = di.depth_m[k];
        if (!(d_here > 0.f)) continue;
        // 1. Find the pixel of j that sees this pixel's point (nearest pixel).
        const Eigen::Vector3d p_j =
            R_ji * (d_here * Eigen::Vector3d(x_of_u[static_cast<size_t>(u)], y, 1.0)) + t_ji;
        if (p_j.z() <= 1e-6) continue;
        const double inv_z = 1.0 / p_j.z();
        const long uj = nearest_pixel(camera.fx * p_j.x() * inv_z + camera.cx);
        const long vj = nearest_pixel(camera.fy * p_j.y() * inv_z + camera.cy);
        if (uj < 0 || vj < 0 || uj >= dj.width || vj >= dj.height) continue;
        const float zj = dj.at(static_cast<int>(uj), static_cast<int>(vj));
        if (!(zj > 0.f)) continue;
        // 2. Re-project j's depth there into i: the projected depth d_j^i.
        const Eigen::Vector3d q_j = zj * Eigen::Vector3d(x_of_u[static_cast<size_t>(uj)],
                                                         y_of_v[static_cast<size_t>(vj)], 1.0);
        const double projected = z_row_ij.dot(q_j) + z_t_ij;
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
    if (successes[k] >= alpha)
      out.depth_m[k] = (d + sums[k]) / static_cast<float>(successes[k] + 1);
  }
  if (stats != nullptr) {
    stats->input_valid = in_valid;
    stats->output_valid = out.CountValid();
  }
  return out;
}

}  // namespace mapdelta::client

#pragma once
// Stage 2: the paper's temporal depth filter (section III-A-2). For keyframe i and each
// neighbour j = i-w..i+w (j != i), the depth of j at the pixel corresponding to i's pixel is
// re-projected into i (the projected depth d_j^i); it succeeds if it differs from d_i by less
// than delta_d. Pixels with at least alpha successes keep the average of d_i and the
// successful projected depths; all others are dropped.
// Why gather (look up j from i) rather than scatter (splat every pixel of j into i): with a
// forward-moving camera, half of the neighbours are farther away, and their splats leave
// holes in i that would count as failures; gather gives each pixel of i one fair test per
// neighbour.
#include <vector>

#include "mapdelta/client/config.hpp"
#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta::client {

struct DepthFrame {
  SE3 T_world_cam = SE3::Identity();  // any consistent world frame (odometry is enough)
  const DepthImage* depth = nullptr;
};

struct TemporalFilterStats {
  size_t input_valid = 0;
  size_t output_valid = 0;
};

// frames: the window, center: index of keyframe i in it. Neighbours absent at sequence ends
// simply are not in the window (then fewer than alpha successes are possible; alpha is
// clamped to the number of neighbours present so the first/last keyframes still get depth).
DepthImage TemporalFilter(const std::vector<DepthFrame>& frames, size_t center,
                          const PinholeCamera& camera, const TemporalFilterConfig& config,
                          TemporalFilterStats* stats = nullptr);

}  // namespace mapdelta::client

#pragma once
// Stage 2: the paper's temporal depth filter (section III-A-2). For keyframe i, every depth
// pixel of the neighbours j = i-w..i+w (j != i) is re-projected into i; a projection succeeds
// if its depth differs from d_i at the hit pixel by less than delta_d. Pixels with at least
// alpha successes (counted once per neighbour) keep the average of d_i and the successful
// projected depths; all others are dropped.
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

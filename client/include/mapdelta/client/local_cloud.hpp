#pragma once
// Stage 3: a local cloud from the filtered depth of consecutive keyframes (paper: 5 keyframes,
// voxel 0.4 m, max depth 50 m), expressed in the body frame of an anchor keyframe through the
// odometry's relative poses, which are accurate over such a short stretch.
#include <vector>

#include "mapdelta/client/config.hpp"
#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta::client {

struct LocalCloudFrame {
  SE3 T_odom_body = SE3::Identity();
  const DepthImage* depth = nullptr;
};

// Points of all frames in the anchor body frame: p_anchor = T_odom_anchor^-1 T_odom_body
// T_body_cam p_cam. Every pixel_stride-th pixel with 0 < depth <= max_depth_m, then voxel
// downsampled (centroids). Throws Error(kInvalidArgument) on a depth/camera size mismatch.
PointCloud BuildLocalCloud(const std::vector<LocalCloudFrame>& frames, const SE3& T_odom_anchor,
                           const PinholeCamera& camera, const SE3& T_body_cam,
                           const LocalCloudConfig& config);

}  // namespace mapdelta::client

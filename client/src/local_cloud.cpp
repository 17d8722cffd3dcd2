#include "mapdelta/client/local_cloud.hpp"

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta::client {

PointCloud BuildLocalCloud(const std::vector<LocalCloudFrame>& frames, const SE3& T_odom_anchor,
                           const PinholeCamera& camera, const SE3& T_body_cam,
                           const LocalCloudConfig& config) {
  PointCloud cloud;
  const SE3 T_anchor_odom = T_odom_anchor.inverse();
  const int stride = std::max(1, config.pixel_stride);
  for (const auto& frame : frames) {
    if (frame.depth == nullptr) continue;
    const DepthImage& depth = *frame.depth;
    if (depth.width != camera.width || depth.height != camera.height) {
      throw Error(ErrorCode::kInvalidArgument, "local cloud: depth image size differs from camera");
    }
    const SE3 T_anchor_cam = T_anchor_odom * frame.T_odom_body * T_body_cam;
    for (int v = 0; v < depth.height; v += stride) {
      for (int u = 0; u < depth.width; u += stride) {
        const float z = depth.at(u, v);
        if (!(z > 0.f) || z > config.max_depth_m) continue;
        cloud.push_back((T_anchor_cam * camera.BackProject(u, v, z)).cast<float>());
      }
    }
  }
  return VoxelDownsample(cloud, static_cast<float>(config.voxel_m));
}

}  // namespace mapdelta::client

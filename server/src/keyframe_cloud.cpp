#include "keyframe_cloud.hpp"

#include <cstdio>

#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta::server {

PointCloud KeyframeCloud(const PinholeCamera& camera, const SE3& T_map_cam, const DepthImage& depth,
                         const PipelineConfig& p) {
  PointCloud points;
  const int stride = p.pixel_stride;
  for (int v = 0; v < depth.height; v += stride) {
    for (int u = 0; u < depth.width; u += stride) {
      const float z = depth.at(u, v);
      if (!(z > 0.f) || z >= p.max_depth_m) continue;
      points.push_back((T_map_cam * camera.BackProject(u, v, z)).cast<float>());
    }
  }
  return VoxelDownsample(points, static_cast<float>(p.session_voxel_m));
}

std::string KeyframeCloudParams(const PipelineConfig& p) {
  char text[160];
  std::snprintf(text, sizeof text, "v1 stride=%d max_depth_m=%.17g voxel_m=%.17g", p.pixel_stride,
                p.max_depth_m, p.session_voxel_m);
  return text;
}

}  // namespace mapdelta::server

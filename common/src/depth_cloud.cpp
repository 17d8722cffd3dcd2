#include "mapdelta/common/depth_cloud.hpp"

#include <cmath>
#include <string>

#include "mapdelta/common/error.hpp"

namespace mapdelta {

PointCloud DepthToCloud(const PinholeCamera& camera, const DepthImage& depth,
                        const SE3& T_frame_cam, double max_depth_m, int stride) {
  if (depth.width != camera.width || depth.height != camera.height ||
      depth.depth_m.size() != static_cast<size_t>(depth.width) * depth.height) {
    throw Error(ErrorCode::kInvalidArgument, "depth image is " + std::to_string(depth.width) + "x" +
                                                 std::to_string(depth.height) + ", camera is " +
                                                 std::to_string(camera.width) + "x" +
                                                 std::to_string(camera.height));
  }
  if (stride < 1) throw Error(ErrorCode::kInvalidArgument, "depth to cloud: stride must be >= 1");
  const Eigen::Isometry3f T = T_frame_cam.cast<float>();
  PointCloud cloud;
  for (int v = 0; v < camera.height; v += stride) {
    for (int u = 0; u < camera.width; u += stride) {
      const float d = depth.at(u, v);
      if (!(std::isfinite(d) && d > 0.f && d < max_depth_m)) continue;
      cloud.push_back(T * camera.BackProject(u, v, d).cast<float>());
    }
  }
  return cloud;
}

}  // namespace mapdelta

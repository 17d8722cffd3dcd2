#pragma once
// A synthetic world with analytic ground truth for server tests and the server benchmark:
// a ground plane z = ground_z and axis-aligned boxes. Depth is rendered by exact ray casting, prior
// clouds are surface samples, so the true new/removed regions are known exactly.
#include <vector>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta::testing {

struct Box {
  Eigen::Vector3d min, max;
  double Distance(const Eigen::Vector3d& p) const;  // 0 inside, else Euclidean distance
};

struct BoxScene {
  AxisAlignedBox ground;  // x/y extent of the ground plane
  double ground_z = 0.0;  // height of the ground plane
  std::vector<Box> boxes;

  // Depth (metres along the optical axis) of the first surface hit per pixel; 0 if none or
  // beyond max_depth_m.
  DepthImage Render(const PinholeCamera& camera, const SE3& T_map_cam, double max_depth_m) const;
  // Ground and box surfaces (not box bottoms) sampled on a grid of `spacing_m`.
  PointCloud Sample(double spacing_m) const;
};

// A camera at (x, y, height) looking along -y (map), optical axis pitched down by pitch_rad.
SE3 CameraLookingMinusY(double x, double y, double height, double pitch_rad = 0.0);

}  // namespace mapdelta::testing

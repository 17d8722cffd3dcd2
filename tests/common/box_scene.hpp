#pragma once
// A synthetic world with analytic ground truth for change-detection tests: axis-aligned boxes
// sampled as surface points, and depth images rendered by exact ray/box intersection.
#include <vector>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta::testing {

struct Box {
  Eigen::Vector3d min, max;
};

// Points on all six faces of every box on a grid of `spacing` metres.
PointCloud SampleBoxSurfaces(const std::vector<Box>& boxes, double spacing);
// Depth (along the optical axis) of the first box hit by each pixel's ray; 0 where nothing is hit.
DepthImage RenderDepth(const PinholeCamera& camera, const SE3& T_map_cam,
                       const std::vector<Box>& boxes);
// Camera at `eye` looking at `target` with the map z axis up (camera x right, y down, z forward).
SE3 LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target);

// Ground 80 x 80 m; buildings A and C stay, B (x 11..19, y -19..-11) is removed, D (x 11..19,
// y 11..19) is added; 24 keyframes on a circle of radius 30 m at 25 m height look at the centre,
// depth rendered from the changed scene. (Steep views on purpose: grazing rays near th_d mark
// ground voxels observed where the global cloud is sparse, the method's known false-removed
// pattern, which these tests do not study.)
struct BoxWorld {
  std::vector<Box> original, changed;
  KeyframeFolder keyframes;
};
BoxWorld MakeBoxWorld();

}  // namespace mapdelta::testing

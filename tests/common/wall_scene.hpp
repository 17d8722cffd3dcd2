#pragma once
// The small camera, flat-wall depth images and downward keyframes the observed-area and
// change-detection tests share.
#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/observed_area.hpp"

namespace mapdelta::testing {

inline PinholeCamera SmallCamera() {
  PinholeCamera camera;
  camera.width = 128;  // rays ~0.24 m apart at 19 m: no gaps between them at 0.4 m voxels
  camera.height = 96;
  camera.fx = camera.fy = 80.0;
  camera.cx = 64.0;
  camera.cy = 48.0;
  return camera;
}

// Every pixel at depth z (0 = no depth anywhere).
inline DepthImage Wall(const PinholeCamera& camera, float z) {
  DepthImage depth(camera.width, camera.height);
  for (auto& d : depth.depth_m) d = z;
  return depth;
}

// A keyframe at `position` looking straight down (image x along map x, image y along map -y),
// every pixel at the depth of the ground z = 0 below; the tests then raise objects in it.
inline Keyframe DownwardKeyframe(const PinholeCamera& camera, int64_t t_ns,
                                 const Eigen::Vector3d& position) {
  Keyframe keyframe;
  keyframe.t_ns = t_ns;
  keyframe.T_map_cam.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();  // optical axis down
  keyframe.T_map_cam.translation() = position;
  keyframe.depth = Wall(camera, static_cast<float>(position.z()));
  return keyframe;
}

// The paper's rule at a 0.4 m octree, 0.2 m end-point prefilter and th_f 20 m.
inline ObservedAreaParams SmallSceneParams() {
  ObservedAreaParams params;
  params.resolution_m = 0.4;
  params.prefilter_voxel_m = 0.2;
  params.free_ray_m = 20.0;
  return params;
}

}  // namespace mapdelta::testing

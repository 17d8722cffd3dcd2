#pragma once
// The changed scene shared by the server tests and the server benchmark: a prior with
// boxes A and B, a changed scene with B and a new box C, and cameras that see them.
#include <nlohmann/json.hpp>
#include <string>

#include "box_scene.hpp"
#include "mapdelta/common/depth_image.hpp"

namespace mapdelta::testing {

// The ground sits mid-voxel (octree voxel boundaries are at multiples of 0.8 m), so that
// rays grazing over it do not mark the ground's own voxels as observed free space.
inline constexpr double kGroundZ = -0.4;
// Boxes (5 m) are taller than th_ch but lower than the 8 m high cameras, so their tops are
// seen (a top above the camera is only grazed by free rays at voxel resolution, which the
// method cannot tell from a removal).
inline const Box kBoxA{{14, 10, kGroundZ},
                       {20, 15, 4.6}};  // in the prior, removed in the changed scene
inline const Box kBoxB{{2, 10, kGroundZ}, {7, 15, 4.6}};    // in both
inline const Box kBoxC{{30, 10, kGroundZ}, {36, 15, 4.6}};  // new in the changed scene
inline constexpr double kCameraHeight = 8.0;
inline constexpr double kMaxDepth = 50.0;  // th_d of the paper
inline constexpr double kPitch = 0.35;     // 20 degrees down

inline BoxScene PriorScene() {
  BoxScene s;
  s.ground.min = Eigen::Vector3f(-30, -10, 0);
  s.ground.max = Eigen::Vector3f(70, 40, 0);
  s.ground_z = kGroundZ;
  s.boxes = {kBoxA, kBoxB};
  return s;
}
inline BoxScene ChangedScene() {
  BoxScene s = PriorScene();
  s.boxes = {kBoxB, kBoxC};
  return s;
}

// The benchmarks' 300 m street of 8 m boxes every 30 m; changed: box 3 removed, one added.
inline BoxScene StreetScene(bool changed) {
  BoxScene s;
  s.ground.min = Eigen::Vector3f(-60, -20, 0);
  s.ground.max = Eigen::Vector3f(360, 60, 0);
  s.ground_z = kGroundZ;
  for (int i = 0; i < 10; ++i) {
    if (changed && i == 3) continue;  // removed
    const double x = i * 30.0;
    s.boxes.push_back({{x, 10, kGroundZ}, {x + 8, 16, 4.6}});
  }
  if (changed) s.boxes.push_back({{105, 10, kGroundZ}, {112, 16, 4.6}});  // added
  return s;
}

inline PinholeCamera TestCamera() {
  PinholeCamera c;
  c.width = 160;
  c.height = 90;
  c.fx = c.fy = 80;
  c.cx = 80;
  c.cy = 45;
  return c;
}

inline std::string PngString(const DepthImage& d) {
  const auto png = EncodeDepthPng(d);
  return std::string(png.begin(), png.end());
}

inline nlohmann::json MetaJson(int64_t t_ns, const SE3& T) {
  const Eigen::Quaterniond q(T.rotation());
  const Eigen::Vector3d t = T.translation();
  return nlohmann::json{
      {"t_ns", t_ns},
      {"T_map_cam", {{"t", {t.x(), t.y(), t.z()}}, {"q", {q.w(), q.x(), q.y(), q.z()}}}}};
}

}  // namespace mapdelta::testing

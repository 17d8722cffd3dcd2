#pragma once
// Small multi-view helpers on normalized image coordinates (no Ceres/OpenCV).
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "mapdelta/common/pose.hpp"

namespace mapdelta::vio {

struct StereoExtrinsics {
  SE3 T_body_cam0 = SE3::Identity();
  SE3 T_body_cam1 = SE3::Identity();
  double focal_px = 400.0;  // to express normalized residuals in pixels
  SE3 T_cam0_cam1() const { return T_body_cam0.inverse() * T_body_cam1; }
};

// A ray: origin and direction in one frame.
struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;  // not necessarily unit
};

// Least-squares intersection point of two or more rays (midpoint method); nullopt if the
// rays are (near) parallel: the smallest angle to the others below `min_angle_rad`.
std::optional<Eigen::Vector3d> TriangulateRays(const std::vector<Ray>& rays,
                                               double min_angle_rad = 1e-3);

// Point in cam0 from a stereo observation (normalized left/right); nullopt if the depth is
// not positive or the rays are parallel.
std::optional<Eigen::Vector3d> TriangulateStereo(const Eigen::Vector2d& left,
                                                 const Eigen::Vector2d& right,
                                                 const SE3& T_cam0_cam1);

}  // namespace mapdelta::vio

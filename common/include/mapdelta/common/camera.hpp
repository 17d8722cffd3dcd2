#pragma once
// Pinhole camera and rectified stereo rig. Camera frame: x right, y down, z forward.
#include <Eigen/Core>
#include <optional>

#include "mapdelta/common/pose.hpp"

namespace mapdelta {

struct PinholeCamera {
  int width = 800;
  int height = 450;
  double fx = 400.0, fy = 400.0, cx = 400.0, cy = 225.0;

  // Pixel (u, v) of a point in the camera frame; nullopt behind the camera or outside the image.
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_cam) const;
  // Point in the camera frame at depth z (along the optical axis) through pixel (u, v).
  Eigen::Vector3d BackProject(double u, double v, double z) const;
  bool InImage(double u, double v) const;
  // Throws Error(kInvalidArgument) naming the bad field.
  void Validate() const;
};

struct StereoRig {
  PinholeCamera left;       // cam0; rectified, so cam1 shares intrinsics
  double baseline_m = 1.0;  // cam1 sits at +baseline along cam0's x axis
  SE3 T_body_cam0 = SE3::Identity();

  double DepthFromDisparity(double disparity_px) const {
    return left.fx * baseline_m / disparity_px;
  }
  double DisparityFromDepth(double depth_m) const { return left.fx * baseline_m / depth_m; }
};

}  // namespace mapdelta

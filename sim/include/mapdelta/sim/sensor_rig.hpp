#pragma once
// The sensors the simulator renders and writes: two cameras (pinhole + optional
// radial-tangential distortion, any extrinsics) and the IMU/body frame the sequence uses.
//
// Frames: the trajectory moves the *vehicle* frame (FLU, level, heading along the velocity).
// The written body frame (= IMU frame, identity T_BS in imu0/sensor.yaml) is T_vehicle_body
// from it: identity for the `ideal` rig; for the `euroc` rig it is EuRoC's IMU orientation
// (x up, z forward), so EuRoC MH_01's camera T_BS can be written verbatim.
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/pose.hpp"
#include "mapdelta/sim/config.hpp"

namespace mapdelta::sim {

// Radial-tangential (plumb bob, OpenCV k1 k2 p1 p2) distortion of normalized coordinates.
struct RadTan {
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0;
  bool IsZero() const { return k1 == 0 && k2 == 0 && p1 == 0 && p2 == 0; }
  Eigen::Vector2d Distort(const Eigen::Vector2d& x) const;
  // Inverse of Distort by Newton iterations (converges to 1e-12 on EuRoC-strength lenses);
  // returns false if it did not converge (far outside the lens' valid field).
  bool Undistort(const Eigen::Vector2d& xd, Eigen::Vector2d* x) const;
};

struct SimCamera {
  PinholeCamera K;    // intrinsics of the distorted camera (EuRoC `intrinsics`)
  RadTan distortion;  // zero for ideal pinhole cameras
  SE3 T_body_cam = SE3::Identity();
};

struct SensorRig {
  std::string name;  // "ideal" or "euroc"
  SimCamera cam[2];
  SE3 T_vehicle_body = SE3::Identity();  // rotation only
};

// The rig of a config: `ideal` = cam0 at BodyToCam0() with the config's intrinsics and cam1 at
// +baseline along cam0's x; `euroc` = EuRoC MH_01's calibration (the config's camera fields
// are ignored). Throws Error(kInvalidArgument) for an unknown rig name.
SensorRig MakeSensorRig(const SimConfig& config);
SensorRig EurocMh01Rig();

// Unnormalized ray directions (z = 1 in the camera) of every pixel centre, row-major; for a
// distorted camera the pixel is undistorted first. Pixels whose undistortion fails get (0,0,0).
std::vector<Eigen::Vector3f> PixelRays(const SimCamera& camera);

}  // namespace mapdelta::sim

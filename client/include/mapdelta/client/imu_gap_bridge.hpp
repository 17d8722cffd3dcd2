#pragma once
// Across an odometry reset (the VIO lost track and re-initialized in a new world frame with an
// arbitrary yaw), the IMU still ran. Integrating the gyro over the gap gives the body's
// rotation from the last pose before it to the first after it to a fraction of a degree, and
// with it the new segment's heading in the old frame; the path follows from a body-frame
// velocity interpolated between the two segments' estimates and turned by that attitude (a
// car's velocity stays near fixed in its body frame). The position is only as good as the
// speed profile guess (a stop during the gap), the heading far better.
// Why: without it the client re-anchored the new segment among 12 evenly spaced headings; on
// paper S1_dark (a 10 s gap around a 90 deg turn) it picked one 90 deg off that fitted the
// street as well, and every later keyframe went 15-71 m astray (docs/results.md, session 22).
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta::client {

// A new odometry segment's first pose in the previous segment's odometry frame, and its
// uncertainty (6x6 [rotation, translation], right perturbation).
struct OdometryBridge {
  SE3 T_prev_odom_body = SE3::Identity();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
};

// One end of the gap as the odometry estimated it: time, pose and velocity in that segment's
// (gravity-aligned) odometry frame.
struct GapEnd {
  int64_t t_ns = 0;
  SE3 T_odom_body = SE3::Identity();
  Eigen::Vector3d v_odom = Eigen::Vector3d::Zero();
};

struct GapBridgeNoise {
  double rot_sigma_rad = 0.01;         // gyro integration, plus ...
  double rot_sigma_per_s = 0.003;      // ... bias instability per second of gap
  double trans_sigma_m = 0.5;          // plus this fraction of the distance covered:
  double trans_sigma_per_path = 0.25;  // the speed profile in between is a guess
};

// The pose of `after` (in its new segment's frame) in `before`'s frame. `imu`: samples in time
// order covering the gap (others are skipped), in the IMU frame; `R_body_imu` turns them into the
// body frame; `gyro_bias` (IMU frame) is the odometry's last estimate before the gap. Nothing
// when the IMU does not cover the gap (a hole longer than `max_imu_gap_s`).
std::optional<OdometryBridge> BridgeGap(const GapEnd& before, const GapEnd& after,
                                        const std::vector<ImuSample>& imu,
                                        const Eigen::Matrix3d& R_body_imu,
                                        const Eigen::Vector3d& gyro_bias,
                                        const GapBridgeNoise& noise = {},
                                        double max_imu_gap_s = 0.1);

}  // namespace mapdelta::client

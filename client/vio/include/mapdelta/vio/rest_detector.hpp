#pragma once
// Rest from the IMU alone: the statistics of a stretch of samples and whether they look like a
// vehicle standing still (StaticInitConfig). At rest the mean gyro reading is the gyro bias and
// the mean accelerometer reading is the specific force of gravity, i.e. "up" in the body frame
// plus the accelerometer bias (which rest cannot separate from tilt: with EuRoC V1_01's
// 0.55 m/s^2 that is 3 deg). The caller confirms rest with vision (initializer.hpp).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "mapdelta/common/euroc.hpp"
#include "mapdelta/vio/types.hpp"

namespace mapdelta::vio {

struct ImuRestStats {
  int samples = 0;
  double span_s = 0;
  Eigen::Vector3d gyro_mean = Eigen::Vector3d::Zero();   // rad/s
  Eigen::Vector3d accel_mean = Eigen::Vector3d::Zero();  // m/s^2, specific force
  double gyro_std = 0, accel_std = 0;  // norms of the per-axis standard deviations
};

// Samples in time order (duplicate timestamps are counted once).
ImuRestStats MeasureImuRest(const std::vector<ImuSample>& samples);

struct RestCheck {
  bool at_rest = false;
  std::string reason;  // why not, for the debug log
  ImuRestStats stats;
};

// At rest if the samples span at least 90 % of config.window_s, their spread is below the
// limits and |mean accel| is gravity within max_gravity_error.
RestCheck CheckImuRest(const std::vector<ImuSample>& samples, const StaticInitConfig& config,
                       double gravity);

}  // namespace mapdelta::vio

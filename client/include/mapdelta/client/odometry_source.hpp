#pragma once
// Where the odometry comes from. The VIO (client/vio, mapdelta_vio) plugs in behind this
// interface; until then any trajectory file (TUM or EuRoC CSV, T_odom_body) feeds the fusion.
#include <Eigen/Core>
#include <optional>
#include <string>

#include "mapdelta/common/pose.hpp"

namespace mapdelta::client {

struct OdometrySample {
  SE3 T_odom_body = SE3::Identity();
  // Covariance of the motion since the previous sample asked for, if the source knows it.
  std::optional<Eigen::Matrix<double, 6, 6>> rel_covariance;
};

class OdometrySource {
 public:
  virtual ~OdometrySource() = default;
  // The odometry pose at an image time; nullopt if the source has none (not initialized yet,
  // or outside the trajectory). Called with increasing t_ns.
  virtual std::optional<OdometrySample> At(int64_t t_ns) = 0;
};

// A recorded trajectory, interpolated at the asked times. Throws Error naming the file.
class TrajectoryOdometrySource : public OdometrySource {
 public:
  explicit TrajectoryOdometrySource(const std::string& path);
  explicit TrajectoryOdometrySource(Trajectory trajectory);
  std::optional<OdometrySample> At(int64_t t_ns) override;
  size_t size() const { return trajectory_.size(); }

 private:
  Trajectory trajectory_;
};

}  // namespace mapdelta::client

#include "mapdelta/client/odometry_source.hpp"

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/trajectory_io.hpp"

namespace mapdelta::client {

TrajectoryOdometrySource::TrajectoryOdometrySource(const std::string& path)
    : TrajectoryOdometrySource(ReadTrajectory(path)) {
  if (trajectory_.empty()) throw Error(ErrorCode::kParse, path + ": odometry trajectory is empty");
}

TrajectoryOdometrySource::TrajectoryOdometrySource(Trajectory trajectory)
    : trajectory_(std::move(trajectory)) {}

std::optional<OdometrySample> TrajectoryOdometrySource::At(int64_t t_ns) {
  SE3 T;
  if (!InterpolateAt(trajectory_, t_ns, &T)) return std::nullopt;
  return OdometrySample{T, std::nullopt};
}

}  // namespace mapdelta::client

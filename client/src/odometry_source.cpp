#include "mapdelta/client/odometry_source.hpp"

#include <cmath>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/trajectory_io.hpp"

namespace mapdelta::client {

TrajectoryOdometrySource::TrajectoryOdometrySource(const std::string& path)
    : TrajectoryOdometrySource(ReadTrajectory(path)) {
  if (trajectory_.empty()) throw Error(ErrorCode::kParse, path + ": odometry trajectory is empty");
}

TrajectoryOdometrySource::TrajectoryOdometrySource(Trajectory trajectory)
    : trajectory_(std::move(trajectory)) {}

std::optional<OdometrySample> TrajectoryOdometrySource::At(int64_t t_ns,
                                                           const StereoImages* /*images*/) {
  SE3 T;
  if (!InterpolateAt(trajectory_, t_ns, &T)) return std::nullopt;
  OdometrySample sample;
  sample.T_odom_body = T;
  return sample;
}

InjectedResetOdometrySource::InjectedResetOdometrySource(OdometrySource* inner, int64_t reset_t_ns,
                                                         double gap_s, const SE3& T_new_old,
                                                         const std::vector<ImuSample>* imu,
                                                         const Eigen::Matrix3d& R_body_imu)
    : inner_(inner),
      reset_t_ns_(reset_t_ns),
      gap_end_t_ns_(reset_t_ns + static_cast<int64_t>(std::llround(gap_s * 1e9))),
      T_new_old_(T_new_old),
      imu_(imu),
      R_body_imu_(R_body_imu) {
  if (inner == nullptr)
    throw Error(ErrorCode::kInvalidArgument, "InjectedResetOdometrySource: no inner source");
  if (!(gap_s >= 0))
    throw Error(ErrorCode::kInvalidArgument, "InjectedResetOdometrySource: gap_s must be >= 0");
  if (!IsValidPose(T_new_old, 1e-6)) {
    throw Error(ErrorCode::kInvalidArgument,
                "InjectedResetOdometrySource: T_new_old is not a rigid transform");
  }
}

std::optional<OdometrySample> InjectedResetOdometrySource::At(int64_t t_ns,
                                                              const StereoImages* images) {
  std::optional<OdometrySample> sample = inner_->At(t_ns, images);
  if (!sample || t_ns < reset_t_ns_) {
    if (sample) {
      last_before_ = sample;
      last_before_t_ns_ = t_ns;
    }
    return sample;
  }
  if (t_ns < gap_end_t_ns_) return std::nullopt;
  const bool first_after = last_before_.has_value();
  sample->T_odom_body = T_new_old_ * sample->T_odom_body;
  if (sample->v_odom) sample->v_odom = T_new_old_.linear() * *sample->v_odom;
  sample->rel_covariance.reset();  // the first step after the reset has no known motion
  ++sample->segment;
  if (first_after && imu_ != nullptr && last_before_->v_odom && last_before_->gyro_bias &&
      sample->v_odom) {
    sample->bridge = BridgeGap(
        {last_before_t_ns_, last_before_->T_odom_body, *last_before_->v_odom},
        {t_ns, sample->T_odom_body, *sample->v_odom}, *imu_, R_body_imu_, *last_before_->gyro_bias);
  }
  last_before_.reset();
  return sample;
}

bool InjectedResetOdometrySource::GravityAligned() const {
  return inner_->GravityAligned() &&
         (T_new_old_.linear() * Eigen::Vector3d::UnitZ()).z() > 1.0 - 1e-9;
}

}  // namespace mapdelta::client

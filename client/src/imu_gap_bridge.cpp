#include "mapdelta/client/imu_gap_bridge.hpp"

#include <algorithm>
#include <cmath>

namespace mapdelta::client {

std::optional<OdometryBridge> BridgeGap(const GapEnd& before, const GapEnd& after,
                                        const std::vector<ImuSample>& imu,
                                        const Eigen::Matrix3d& R_body_imu,
                                        const Eigen::Vector3d& gyro_bias,
                                        const GapBridgeNoise& noise, double max_imu_gap_s) {
  if (after.t_ns <= before.t_ns) return std::nullopt;
  const double gap_s = 1e-9 * static_cast<double>(after.t_ns - before.t_ns);
  const int64_t max_hold_ns = static_cast<int64_t>(std::llround(max_imu_gap_s * 1e9));
  // Each reading holds from its time until the next sample's.
  auto next = std::upper_bound(imu.begin(), imu.end(), before.t_ns,
                               [](int64_t t, const ImuSample& s) { return t < s.t_ns; });
  if (next == imu.begin()) return std::nullopt;
  const ImuSample* reading = &*std::prev(next);
  // Body-frame velocity at both ends; linear in time in between.
  const Eigen::Vector3d v_body_before = before.T_odom_body.linear().transpose() * before.v_odom;
  const Eigen::Vector3d v_body_after = after.T_odom_body.linear().transpose() * after.v_odom;
  // Attitude relative to `before`'s body, and position in `before`'s odometry frame. Only the
  // gyro is integrated (the accelerometer's double integral over seconds is worse than the
  // interpolated velocity), so the VIO's preintegration is not needed here; mapdelta_client
  // does not link the VIO library.
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  double path_m = 0;
  for (int64_t t = before.t_ns; t < after.t_ns;) {
    const int64_t t_next = next != imu.end() ? std::min(after.t_ns, next->t_ns) : after.t_ns;
    if (t_next - reading->t_ns > max_hold_ns) return std::nullopt;  // a hole in the IMU
    const double dt = 1e-9 * static_cast<double>(t_next - t);
    const double s = (1e-9 * static_cast<double>(t - before.t_ns) + 0.5 * dt) / gap_s;
    const Eigen::Vector3d v_body = (1.0 - s) * v_body_before + s * v_body_after;
    p += before.T_odom_body.linear() * R * v_body * dt;
    path_m += v_body.norm() * dt;
    R = R * ExpSO3(R_body_imu * (reading->gyro - gyro_bias) * dt);
    t = t_next;
    if (next != imu.end() && next->t_ns <= t) reading = &*next++;
  }
  OdometryBridge bridge;
  bridge.T_prev_odom_body.linear() = before.T_odom_body.linear() * R;
  bridge.T_prev_odom_body.translation() = before.T_odom_body.translation() + p;
  const double sr = noise.rot_sigma_rad + noise.rot_sigma_per_s * gap_s;
  const double st = noise.trans_sigma_m + noise.trans_sigma_per_path * path_m;
  bridge.covariance.setZero();
  bridge.covariance.diagonal() << Eigen::Vector3d::Constant(sr * sr),
      Eigen::Vector3d::Constant(st * st);
  return bridge;
}

}  // namespace mapdelta::client

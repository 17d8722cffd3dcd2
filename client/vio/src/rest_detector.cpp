#include "mapdelta/vio/rest_detector.hpp"

#include <cmath>
#include <sstream>

namespace mapdelta::vio {

ImuRestStats MeasureImuRest(const std::vector<ImuSample>& samples) {
  ImuRestStats s;
  // Two passes (mean, then spread about it): the readings are offsets of ~10 m/s^2 with
  // spreads of 1e-2, where the one-pass sum of squares loses digits.
  std::vector<const ImuSample*> unique;
  for (const auto& sample : samples) {
    if (unique.empty() || sample.t_ns > unique.back()->t_ns) unique.push_back(&sample);
  }
  if (unique.empty()) return s;
  s.samples = static_cast<int>(unique.size());
  s.span_s = 1e-9 * static_cast<double>(unique.back()->t_ns - unique.front()->t_ns);
  for (const ImuSample* p : unique) {
    s.gyro_mean += p->gyro;
    s.accel_mean += p->accel;
  }
  s.gyro_mean /= s.samples;
  s.accel_mean /= s.samples;
  Eigen::Vector3d gyro_var = Eigen::Vector3d::Zero(), accel_var = Eigen::Vector3d::Zero();
  for (const ImuSample* p : unique) {
    gyro_var += (p->gyro - s.gyro_mean).cwiseAbs2();
    accel_var += (p->accel - s.accel_mean).cwiseAbs2();
  }
  s.gyro_std = std::sqrt(gyro_var.sum() / s.samples);
  s.accel_std = std::sqrt(accel_var.sum() / s.samples);
  return s;
}

RestCheck CheckImuRest(const std::vector<ImuSample>& samples, const StaticInitConfig& config,
                       double gravity) {
  RestCheck check;
  check.stats = MeasureImuRest(samples);
  const ImuRestStats& s = check.stats;
  std::ostringstream why;
  const double gravity_error = std::abs(s.accel_mean.norm() - gravity) / gravity;
  if (s.samples < 3 || s.span_s < 0.9 * config.window_s) {
    why << s.samples << " IMU samples over " << s.span_s << " s (window " << config.window_s
        << " s)";
  } else if (s.gyro_std > config.max_gyro_std) {
    why << "gyro spread " << s.gyro_std << " rad/s > " << config.max_gyro_std;
  } else if (s.accel_std > config.max_accel_std) {
    why << "accelerometer spread " << s.accel_std << " m/s^2 > " << config.max_accel_std;
  } else if (gravity_error > config.max_gravity_error) {
    why << "|mean accel| " << s.accel_mean.norm() << " m/s^2 is not gravity " << gravity;
  } else {
    check.at_rest = true;
  }
  check.reason = why.str();
  return check;
}

}  // namespace mapdelta::vio

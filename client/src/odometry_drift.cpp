#include "mapdelta/client/odometry_drift.hpp"

#include <cmath>
#include <random>

namespace mapdelta::client {

Trajectory AddDrift(const Trajectory& gt, const DriftParams& p) {
  Trajectory out;
  if (gt.empty()) return out;
  std::mt19937 rng(p.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double deg = M_PI / 180.0;
  SE3 T = SE3::Identity();
  out.push_back({gt[0].t_ns, T});
  for (size_t k = 1; k < gt.size(); ++k) {
    SE3 step = gt[k - 1].T.inverse() * gt[k].T;
    const double d = step.translation().norm();
    const double s = std::sqrt(d);
    const Eigen::Vector3d w(
        p.rot_noise_deg_per_sqrt_m * s * deg * normal(rng),
        (p.pitch_deg_per_m * d + p.rot_noise_deg_per_sqrt_m * s * normal(rng)) * deg,
        (p.yaw_deg_per_m * d + p.rot_noise_deg_per_sqrt_m * s * normal(rng)) * deg);
    step.linear() = step.linear() * ExpSO3(w);
    step.translation() =
        step.translation() * (1.0 + p.scale_error) +
        p.trans_noise_per_sqrt_m * s * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    T = T * step;
    out.push_back({gt[k].t_ns, T});
  }
  return out;
}

}  // namespace mapdelta::client

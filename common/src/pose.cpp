#include "mapdelta/common/pose.hpp"

#include <algorithm>
#include <cmath>

namespace mapdelta {

SE3 MakeSE3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
  SE3 T = SE3::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& omega) {
  const double angle = omega.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
}

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

double RotationAngle(const SE3& a, const SE3& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

SE3 Interpolate(const SE3& a, const SE3& b, double s) {
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  return MakeSE3(qa.slerp(s, qb), (1.0 - s) * a.translation() + s * b.translation());
}

bool InterpolateAt(const Trajectory& trajectory, int64_t t_ns, SE3* T) {
  if (trajectory.empty() || t_ns < trajectory.front().t_ns || t_ns > trajectory.back().t_ns) {
    return false;
  }
  auto it = std::lower_bound(trajectory.begin(), trajectory.end(), t_ns,
                             [](const StampedPose& p, int64_t t) { return p.t_ns < t; });
  if (it->t_ns == t_ns) {
    *T = it->T;
    return true;
  }
  const auto& after = *it;
  const auto& before = *(it - 1);
  const double s = static_cast<double>(t_ns - before.t_ns) / (after.t_ns - before.t_ns);
  *T = Interpolate(before.T, after.T, s);
  return true;
}

bool IsValidPose(const SE3& T, double tolerance) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < tolerance &&
         std::abs(R.determinant() - 1.0) < tolerance;
}

}  // namespace mapdelta

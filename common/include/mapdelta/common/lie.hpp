#pragma once
// The rotation group's maps and the linear algebra around them, in one place for registration,
// the client's fusion and the VIO. Rotation vectors are axis * angle (radians); quaternions are
// Hamilton (Eigen). Templated on the scalar where a Ceres autodiff cost calls them (T =
// ceres::Jet: only comparisons on the value, std functions found by argument-dependent lookup),
// so no Ceres header is needed here. The same maps on rotation matrices, ExpSO3 and LogSO3, are
// in pose.hpp.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace mapdelta {

// [v]x: Skew(v) * w == v.cross(w).
template <typename Derived>
Eigen::Matrix<typename Derived::Scalar, 3, 3> Skew(const Eigen::MatrixBase<Derived>& v) {
  using T = typename Derived::Scalar;
  Eigen::Matrix<T, 3, 3> S;
  S << T(0), -v(2), v(1), v(2), T(0), -v(0), -v(1), v(0), T(0);
  return S;
}

// Exp of a rotation vector as a unit quaternion. Below 1e-8 rad the first-order quaternion
// (normalized) avoids dividing by the angle.
inline Eigen::Quaterniond ExpQuaternion(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  if (theta < 1e-8) {
    return Eigen::Quaterniond(1.0, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z()).normalized();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(theta, phi / theta));
}

// Log of a unit quaternion as a rotation vector with angle in [0, pi] (q and -q give the same).
// Differentiable through jets: where the vector part vanishes, the first-order 2 v / w.
template <typename T>
Eigen::Matrix<T, 3, 1> LogQuaternion(const Eigen::Quaternion<T>& q) {
  using std::atan2;
  using std::sqrt;
  const T s2 = q.vec().squaredNorm();
  if (s2 > T(0)) {
    const T s = sqrt(s2);
    // Half the angle, of the representative with w >= 0.
    const T half = q.w() < T(0) ? atan2(-s, -q.w()) : atan2(s, q.w());
    return (T(2) * half / s) * q.vec();
  }
  return (T(2) / q.w()) * q.vec();
}

// Right Jacobian of SO(3), Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d), and its inverse; series
// below 1e-5 rad, where the closed forms lose digits.
inline Eigen::Matrix3d RightJacobianSO3(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d W = Skew(phi);
  if (theta < 1e-5) return Eigen::Matrix3d::Identity() - 0.5 * W + W * W / 6.0;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(theta)) / t2 * W +
         (theta - std::sin(theta)) / (t2 * theta) * W * W;
}
inline Eigen::Matrix3d RightJacobianInvSO3(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d W = Skew(phi);
  if (theta < 1e-5) return Eigen::Matrix3d::Identity() + 0.5 * W + W * W / 12.0;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + 0.5 * W +
         (1.0 / t2 - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta))) * W * W;
}

// Which eigenvalues of a symmetric positive semi-definite matrix a pseudo-inverse treats as
// zero: those not above max(absolute, relative_to_largest * the largest eigenvalue).
struct EigenvalueCutoff {
  double absolute = 0;
  double relative_to_largest = 0;
};

// Pseudo-inverse of a symmetric positive semi-definite matrix (of its symmetric part) by
// eigen-decomposition, with the directions below `cutoff` left out.
inline Eigen::MatrixXd PseudoInverse(const Eigen::MatrixXd& A, EigenvalueCutoff cutoff) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (A + A.transpose()));
  const Eigen::VectorXd& ev = es.eigenvalues();
  const double floor =
      ev.size() == 0 ? 0.0 : std::max(cutoff.absolute, cutoff.relative_to_largest * ev.maxCoeff());
  const Eigen::VectorXd inv = (ev.array() > floor).select(ev.array().inverse(), 0.0);
  return es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
}

}  // namespace mapdelta

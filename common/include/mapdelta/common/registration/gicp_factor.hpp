#pragma once
// One GICP correspondence: residual, Jacobian and weight. Inline because it is the inner loop
// of AlignGicp; public so tests can check the Jacobian against numeric differences.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include "mapdelta/common/pose.hpp"

namespace mapdelta {

// Eigenvalue that plane regularization gives the normal direction (tangent directions get 1):
// the value of fast_gicp / small_gicp ("PLANE"), so a surface point constrains mostly along
// its normal whatever the sampling density.
inline constexpr double kPlaneNormalEigenvalue = 1e-3;

// Replaces the eigenvalues of a sample covariance by (1e-3, 1, 1), smallest first.
inline Eigen::Matrix3d RegularizePlaneCovariance(const Eigen::Matrix3d& sample_covariance) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(sample_covariance);
  const Eigen::Vector3d values(kPlaneNormalEigenvalue, 1.0, 1.0);
  const Eigen::Matrix3d& V = eig.eigenvectors();
  return V * values.asDiagonal() * V.transpose();
}

// GICP weight W = (C_target + R C_source R^T)^-1, the inverse covariance of the residual.
inline Eigen::Matrix3d GicpWeight(const Eigen::Matrix3d& target_covariance,
                                  const Eigen::Matrix3d& source_covariance,
                                  const Eigen::Matrix3d& R) {
  return (target_covariance + R * source_covariance * R.transpose()).inverse();
}

inline Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

// r = target_point - T_target_source * source_point. With the right perturbation
// T (+) delta = (R ExpSO3(w), t + R v): T (+) delta * s ~ R s + t + R (w x s) + R v, hence
// dr/dw = R [s]x and dr/dv = -R (W is held fixed, as in GICP's Gauss-Newton).
inline Eigen::Vector3d GicpResidual(const Eigen::Vector3d& target_point,
                                    const Eigen::Vector3d& source_point,
                                    const SE3& T_target_source,
                                    Eigen::Matrix<double, 3, 6>* jacobian) {
  const Eigen::Matrix3d& R = T_target_source.linear();
  if (jacobian != nullptr) {
    jacobian->leftCols<3>() = R * Skew(source_point);
    jacobian->rightCols<3>() = -R;
  }
  return target_point - T_target_source * source_point;
}

}  // namespace mapdelta

#pragma once
// One GICP correspondence: residual, Jacobian and weight. Inline because it is the inner loop
// of AlignGicp; public so tests can check the Jacobian against numeric differences.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>

#include "mapdelta/common/lie.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta {

// Eigenvalue that plane regularization gives the normal direction (tangent directions get 1):
// the value of fast_gicp / small_gicp ("PLANE"), so a surface point constrains mostly along
// its normal whatever the sampling density.
inline constexpr double kPlaneNormalEigenvalue = 1e-3;

// Unit eigenvector of the smallest eigenvalue of a symmetric positive semi-definite 3x3
// matrix, in closed form: the eigenvalue by Newton's method on det(A - l I) from l = 0 (left
// of the smallest root the cubic is decreasing and convex, so the iterates rise monotonically
// to it; 2-4 iterations for a surface patch, no acos/cos), the vector as the longest cross
// product of two rows of (A - l I). False when that eigenvalue is (nearly) repeated and the
// direction is not defined by it alone.
inline bool SmallestEigenvector(const Eigen::Matrix3d& A, Eigen::Vector3d* normal) {
  const double scale = A.cwiseAbs().maxCoeff();
  if (!(scale > 0) || !std::isfinite(scale)) return false;
  const Eigen::Matrix3d B = A * (1.0 / scale);
  // det(B - l I) = -l^3 + c2 l^2 - c1 l + c0.
  const double c2 = B.trace();
  const double c1 = B(0, 0) * B(1, 1) - B(0, 1) * B(0, 1) + B(0, 0) * B(2, 2) - B(0, 2) * B(0, 2) +
                    B(1, 1) * B(2, 2) - B(1, 2) * B(1, 2);
  const double c0 = B.determinant();
  double l = 0;  // c0 <= 0: the smallest eigenvalue is 0 up to rounding
  for (int iteration = 0; c0 > 0; ++iteration) {
    const double f = ((c2 - l) * l - c1) * l + c0;
    const double slope = (2.0 * c2 - 3.0 * l) * l - c1;
    const double step = f / slope;
    l -= step;
    // 1e-12 of the largest entry: the vector's error (~ that / the eigenvalue gap) stays below
    // float precision, in which covariances are stored, for gaps above ~1e-5.
    if (!(std::abs(step) > 1e-12)) break;
    if (iteration == 60) return false;  // a repeated root converges too slowly: no normal
  }
  const Eigen::Matrix3d M = B - l * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d c[3] = {M.row(0).cross(M.row(1)), M.row(0).cross(M.row(2)),
                                M.row(1).cross(M.row(2))};
  int best = 0;
  for (int k = 1; k < 3; ++k) {
    if (c[k].squaredNorm() > c[best].squaredNorm()) best = k;
  }
  // |c| ~ product of the gaps to the other two eigenvalues (relative to the largest).
  const double length = c[best].norm();
  if (!(length > 1e-8)) return false;
  *normal = c[best] * (1.0 / length);
  return true;
}

// The normal used by plane regularization: the unit eigenvector of the sample covariance's
// smallest eigenvalue. Closed form (~40 ns against ~120 ns for Eigen's computeDirect, which
// also finds the other two vectors with acos/cos; measured 2026-12-01); computeDirect where
// the smallest eigenvalue is repeated.
inline Eigen::Vector3d PlaneNormal(const Eigen::Matrix3d& sample_covariance) {
  Eigen::Vector3d n;
  if (SmallestEigenvector(sample_covariance, &n)) return n;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(sample_covariance);
  return eig.eigenvectors().col(0);
}

// Eigenvalues (1e-3, 1, 1) along (normal, tangent, tangent): V diag(1e-3, 1, 1) V^T =
// I - (1 - 1e-3) n n^T. A zero normal gives the identity (isotropic: no usable shape).
inline Eigen::Matrix3d PlaneCovariance(const Eigen::Vector3d& normal) {
  return Eigen::Matrix3d::Identity() - (1.0 - kPlaneNormalEigenvalue) * normal * normal.transpose();
}

// Replaces the eigenvalues of a sample covariance by (1e-3, 1, 1), smallest first.
inline Eigen::Matrix3d RegularizePlaneCovariance(const Eigen::Matrix3d& sample_covariance) {
  return PlaneCovariance(PlaneNormal(sample_covariance));
}

// GICP weight W = (C_target + R C_source R^T)^-1, the inverse covariance of the residual.
inline Eigen::Matrix3d GicpWeight(const Eigen::Matrix3d& target_covariance,
                                  const Eigen::Matrix3d& source_covariance,
                                  const Eigen::Matrix3d& R) {
  return (target_covariance + R * source_covariance * R.transpose()).inverse();
}

// r = target_point - T_target_source * source_point. With the right perturbation
// T (+) delta = (R ExpSO3(w), t + R v): T (+) delta * s ~ R s + t + R (w x s) + R v, hence
// dr/dw = R [s]x and dr/dv = -R (W is held fixed, as in GICP's Gauss-Newton).
inline Eigen::Vector3d GicpResidual(const Eigen::Vector3d& target_point,
                                    const Eigen::Vector3d& source_point, const SE3& T_target_source,
                                    Eigen::Matrix<double, 3, 6>* jacobian) {
  const Eigen::Matrix3d& R = T_target_source.linear();
  if (jacobian != nullptr) {
    jacobian->leftCols<3>() = R * Skew(source_point);
    jacobian->rightCols<3>() = -R;
  }
  return target_point - T_target_source * source_point;
}

}  // namespace mapdelta

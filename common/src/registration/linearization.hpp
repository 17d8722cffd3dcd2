#pragma once
// The Gauss-Newton system of GICP summed over correspondences, one term at a time, computed in
// the source frame. Same H, b, error as J^T W J, J^T W r, r^T W r with the Jacobian of
// gicp_factor.hpp (tests/registration/test_gicp_linearization.cpp checks it against them),
// with one 3x3 similarity and one symmetric 3x3 inverse per term instead of
// (C_t + R C_s R^T)^-1 followed by 6x3 products.
//
// With J = [R S, -R] (S = [s]x) and W = (C_t + R C_s R^T)^-1, let W' = R^T W R =
// (R^T C_t R + C_s)^-1 and u = R^T r. Then
//   J^T W J = [S^T W' S, -S^T W'; -W' S, W'],  J^T W r = [S^T W' u; -W' u],  r^T W r = u^T W' u,
// and S^T = -S turns every product with S into a cross product with s.
#include <Eigen/Core>

#include "mapdelta/common/registration/gicp.hpp"

namespace mapdelta::detail {

struct Linearization {
  Matrix6d H = Matrix6d::Zero();
  Vector6d b = Vector6d::Zero();
  Matrix6d B = Matrix6d::Zero();  // sum of g g^T (g = J^T W r) for the sandwich covariance
  double error = 0;
  double distance_sum = 0;
  size_t inliers = 0;

  void Add(const Linearization& o) {
    H += o.H;
    b += o.b;
    B += o.B;
    error += o.error;
    distance_sum += o.distance_sum;
    inliers += o.inliers;
  }
};

// Inverse of a symmetric positive definite 3x3 matrix by cofactors (symmetric: 6 of them).
inline Eigen::Matrix3d InverseSymmetric3(const Eigen::Matrix3d& C) {
  const double a = C(0, 0), b = C(0, 1), c = C(0, 2), d = C(1, 1), e = C(1, 2), f = C(2, 2);
  const double A00 = d * f - e * e, A01 = c * e - b * f, A02 = b * e - c * d;
  const double A11 = a * f - c * c, A12 = b * c - a * e, A22 = a * d - b * b;
  const double inv_det = 1.0 / (a * A00 + b * A01 + c * A02);
  Eigen::Matrix3d W;
  W << A00, A01, A02, A01, A11, A12, A02, A12, A22;
  return W * inv_det;
}

// The source-frame weight W' = (R^T C_t R + C_s)^-1. Explicit temporaries: with GCC 12 -O3,
// C.noalias() += Rt * Ct.cast<double>() * Rt.transpose() came out wrong by ~1e-9 (relative)
// in some inlining contexts (found by test_gicp_internals; not seen at -O1/-O2).
inline Eigen::Matrix3d SourceFrameWeight(const Eigen::Matrix3d& Rt, const Eigen::Matrix3f& Ct,
                                         const Eigen::Matrix3f& Cs) {
  const Eigen::Matrix3d Ctd = Ct.cast<double>();
  const Eigen::Matrix3d RtC = Rt * Ctd;
  Eigen::Matrix3d C = RtC * Rt.transpose();
  C += Cs.cast<double>();
  return InverseSymmetric3(C);
}

// u^T W' u for the residual r = t - (R s + translation) rotated into the source frame.
inline double WeightedError(const Eigen::Matrix3d& W, const Eigen::Vector3d& u) {
  return u.dot(W * u);
}

// Adds one correspondence: source point s, source-frame residual u = R^T r, weight W'.
inline void AddTerm(const Eigen::Vector3d& s, const Eigen::Vector3d& u, const Eigen::Matrix3d& W,
                    double distance, Linearization* lin) {
  const Eigen::Vector3d Wu = W * u;
  Vector6d g;
  g.head<3>() = Wu.cross(s);  // S^T W' u = -(s x W'u)
  g.tail<3>() = -Wu;
  // M = S W' (column k: s x W'.col(k)) is -S^T W', the rotation-translation block; the
  // rotation block S^T W' S = -M S has rows s x M.row(k).
  Eigen::Matrix3d M;
  for (int k = 0; k < 3; ++k) M.col(k) = s.cross(W.col(k));
  Eigen::Matrix3d Hrr;
  for (int k = 0; k < 3; ++k) Hrr.row(k) = s.cross(Eigen::Vector3d(M.row(k).transpose()));
  lin->H.topLeftCorner<3, 3>() += Hrr;
  lin->H.topRightCorner<3, 3>() += M;
  lin->H.bottomRightCorner<3, 3>() += W;
  lin->b += g;
  lin->B.noalias() += g * g.transpose();
  lin->error += u.dot(Wu);
  lin->distance_sum += distance;
  ++lin->inliers;
}

// H was summed upper blocks only: mirror the rotation-translation block.
inline void CompleteSymmetric(Linearization* lin) {
  lin->H.bottomLeftCorner<3, 3>() = lin->H.topRightCorner<3, 3>().transpose();
}

}  // namespace mapdelta::detail

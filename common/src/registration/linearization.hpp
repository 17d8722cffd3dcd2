#pragma once
// The Gauss-Newton system of GICP summed over correspondences, one term at a time, computed in
// the source frame. Same H, b, error as J^T W J, J^T W r, r^T W r with the Jacobian of
// gicp_factor.hpp (tests/registration/test_gicp_internals.cpp checks it against them),
// with the weight in closed form from the two plane normals (SourceFrameWeight) instead of
// (C_t + R C_s R^T)^-1 followed by 6x3 products.
//
// With J = [R S, -R] (S = [s]x) and W = (C_t + R C_s R^T)^-1, let W' = R^T W R =
// (R^T C_t R + C_s)^-1 and u = R^T r. Then
//   J^T W J = [S^T W' S, -S^T W'; -W' S, W'],  J^T W r = [S^T W' u; -W' u],  r^T W r = u^T W' u,
// and S^T = -S turns every product with S into a cross product with s. Symmetric blocks are
// summed as upper triangles in one flat array (TermSums) and expanded once per pass:
// fewer operations per term than full Eigen 3x3 / 6x6 products.
#include <Eigen/Core>

#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/gicp_factor.hpp"

namespace mapdelta::detail {

// A symmetric 3x3 matrix by its upper triangle.
struct Sym3 {
  double xx, xy, xz, yy, yz, zz;
  Eigen::Vector3d operator*(const Eigen::Vector3d& v) const {
    return {xx * v.x() + xy * v.y() + xz * v.z(), xy * v.x() + yy * v.y() + yz * v.z(),
            xz * v.x() + yz * v.y() + zz * v.z()};
  }
  Eigen::Matrix3d Full() const {
    Eigen::Matrix3d m;
    m << xx, xy, xz, xy, yy, yz, xz, yz, zz;
    return m;
  }
};

// The source-frame weight W' = (R^T C_t R + C_s)^-1 (Rt = R^T) for plane covariances
// C = I - a n n^T (a = 1 - 1e-3; n unit, or zero for the identity), from the two normals:
// with m = R^T n_t and U = [m n_s], R^T C_t R + C_s = 2 I - a U U^T, and by Woodbury
//   W' = (I + a U G^-1 U^T) / 2,  G = 2 I - a U^T U (2x2).
// ~70 operations, against ~110 for the similarity of a full 3x3 and a 3x3 inverse.
inline Sym3 SourceFrameWeight(const Eigen::Matrix3d& Rt, const Eigen::Vector3f& target_normal,
                              const Eigen::Vector3f& source_normal) {
  constexpr double a = 1.0 - kPlaneNormalEigenvalue;
  const Eigen::Vector3d m = Rt * target_normal.cast<double>();
  const Eigen::Vector3d n = source_normal.cast<double>();
  const double g00 = 2.0 - a * m.squaredNorm(), g01 = -a * m.dot(n),
               g11 = 2.0 - a * n.squaredNorm();
  const double inv_det = 1.0 / (g00 * g11 - g01 * g01);
  const double k00 = g11 * inv_det, k01 = -g01 * inv_det, k11 = g00 * inv_det;
  // U G^-1 U^T = p m^T + q n^T (symmetric).
  const Eigen::Vector3d p = a * (k00 * m + k01 * n), q = a * (k01 * m + k11 * n);
  return {0.5 * (1.0 + p.x() * m.x() + q.x() * n.x()), 0.5 * (p.x() * m.y() + q.x() * n.y()),
          0.5 * (p.x() * m.z() + q.x() * n.z()),       0.5 * (1.0 + p.y() * m.y() + q.y() * n.y()),
          0.5 * (p.y() * m.z() + q.y() * n.z()),       0.5 * (1.0 + p.z() * m.z() + q.z() * n.z())};
}

// The source-frame weight for a source point taken as exact (C_s = e I, e = 1e-3, the plane
// covariance's normal eigenvalue): with m = R^T n_t, W' = (R^T C_t R + e I)^-1 =
// (I + c m m^T) / (1 + e), c = a / (1 + e - a m.m) (a / 2e for a unit normal). Point-to-plane
// against the target's surface, as much weight along its normal as two aligned planes get; a
// zero target normal gives (1 + e)^-1 I.
inline Sym3 PointToPlaneWeight(const Eigen::Matrix3d& Rt, const Eigen::Vector3f& target_normal) {
  constexpr double e = kPlaneNormalEigenvalue, a = 1.0 - e;
  const Eigen::Vector3d m = Rt * target_normal.cast<double>();
  const double c = a / (1.0 + e - a * m.squaredNorm()), s = 1.0 / (1.0 + e);
  return {s * (1.0 + c * m.x() * m.x()), s * c * m.x() * m.y(), s * c * m.x() * m.z(),
          s * (1.0 + c * m.y() * m.y()), s * c * m.y() * m.z(), s * (1.0 + c * m.z() * m.z())};
}

// u^T W' u for the residual r = t - (R s + translation) rotated into the source frame.
inline double WeightedError(const Sym3& W, const Eigen::Vector3d& u) { return u.dot(W * u); }

// Running sums of the terms; layout of v: H rotation block (upper, 6), rotation-translation
// block (row-major, 9), translation block (upper, 6), b (6), B = sum g g^T (upper, 21),
// error, distance.
struct TermSums {
  static constexpr int kHrr = 0, kHrt = 6, kHtt = 15, kB = 21, kOuter = 27, kError = 48,
                       kDistance = 49, kSize = 50;
  double v[kSize] = {};
  size_t inliers = 0;

  void Add(const TermSums& o) {
    for (int k = 0; k < kSize; ++k) v[k] += o.v[k];
    inliers += o.inliers;
  }
};

// Adds one correspondence: source point s, source-frame residual u = R^T r, weight W'.
inline void AddTerm(const Eigen::Vector3d& s, const Eigen::Vector3d& u, const Sym3& W,
                    double distance, TermSums* sums) {
  double* v = sums->v;
  const Eigen::Vector3d Wu = W * u;
  const Eigen::Vector3d g_rot = Wu.cross(s);  // S^T W' u = -(s x W'u)
  const double g[6] = {g_rot.x(), g_rot.y(), g_rot.z(), -Wu.x(), -Wu.y(), -Wu.z()};
  // M = S W' (column k: s x W'.col(k)) is -S^T W', the rotation-translation block; the
  // rotation block S^T W' S = -M S has rows s x M.row(k).
  const Eigen::Vector3d c0 = s.cross(Eigen::Vector3d(W.xx, W.xy, W.xz));
  const Eigen::Vector3d c1 = s.cross(Eigen::Vector3d(W.xy, W.yy, W.yz));
  const Eigen::Vector3d c2 = s.cross(Eigen::Vector3d(W.xz, W.yz, W.zz));
  const double M[9] = {c0.x(), c1.x(), c2.x(), c0.y(), c1.y(), c2.y(), c0.z(), c1.z(), c2.z()};
  const double sx = s.x(), sy = s.y(), sz = s.z();
  // Row k of S^T W' S is s x (M[k][0], M[k][1], M[k][2]); upper triangle only.
  v[TermSums::kHrr + 0] += sy * M[2] - sz * M[1];
  v[TermSums::kHrr + 1] += sz * M[0] - sx * M[2];
  v[TermSums::kHrr + 2] += sx * M[1] - sy * M[0];
  v[TermSums::kHrr + 3] += sz * M[3] - sx * M[5];
  v[TermSums::kHrr + 4] += sx * M[4] - sy * M[3];
  v[TermSums::kHrr + 5] += sx * M[7] - sy * M[6];
  for (int k = 0; k < 9; ++k) v[TermSums::kHrt + k] += M[k];
  const double w[6] = {W.xx, W.xy, W.xz, W.yy, W.yz, W.zz};
  for (int k = 0; k < 6; ++k) v[TermSums::kHtt + k] += w[k];
  for (int k = 0; k < 6; ++k) v[TermSums::kB + k] += g[k];
  double* outer = v + TermSums::kOuter;
  for (int i = 0; i < 6; ++i) {
    for (int j = i; j < 6; ++j) *outer++ += g[i] * g[j];
  }
  v[TermSums::kError] += u.dot(Wu);
  v[TermSums::kDistance] += distance;
  ++sums->inliers;
}

struct Linearization {
  Matrix6d H = Matrix6d::Zero();
  Vector6d b = Vector6d::Zero();
  Matrix6d B = Matrix6d::Zero();  // sum of g g^T (g = J^T W r) for the sandwich covariance
  double error = 0;
  double distance_sum = 0;
  size_t inliers = 0;
};

inline Linearization Expand(const TermSums& sums) {
  const double* v = sums.v;
  Linearization lin;
  const int upper[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
  for (int k = 0; k < 6; ++k) {
    const int i = upper[k][0], j = upper[k][1];
    lin.H(i, j) = lin.H(j, i) = v[TermSums::kHrr + k];
    lin.H(3 + i, 3 + j) = lin.H(3 + j, 3 + i) = v[TermSums::kHtt + k];
  }
  for (int k = 0; k < 9; ++k) {
    lin.H(k / 3, 3 + k % 3) = lin.H(3 + k % 3, k / 3) = v[TermSums::kHrt + k];
  }
  for (int k = 0; k < 6; ++k) lin.b(k) = v[TermSums::kB + k];
  const double* outer = v + TermSums::kOuter;
  for (int i = 0; i < 6; ++i) {
    for (int j = i; j < 6; ++j) lin.B(i, j) = lin.B(j, i) = *outer++;
  }
  lin.error = v[TermSums::kError];
  lin.distance_sum = v[TermSums::kDistance];
  lin.inliers = sums.inliers;
  return lin;
}

}  // namespace mapdelta::detail

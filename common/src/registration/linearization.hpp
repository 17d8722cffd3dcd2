#pragma once
// The Gauss-Newton system of GICP summed over correspondences, one term at a time, computed in
// the source frame. Same H, b, error as J^T W J, J^T W r, r^T W r with the Jacobian of
// gicp_factor.hpp (tests/registration/test_gicp_internals.cpp checks it against them),
// with one 3x3 similarity and one symmetric 3x3 inverse per term instead of
// (C_t + R C_s R^T)^-1 followed by 6x3 products.
//
// With J = [R S, -R] (S = [s]x) and W = (C_t + R C_s R^T)^-1, let W' = R^T W R =
// (R^T C_t R + C_s)^-1 and u = R^T r. Then
//   J^T W J = [S^T W' S, -S^T W'; -W' S, W'],  J^T W r = [S^T W' u; -W' u],  r^T W r = u^T W' u,
// and S^T = -S turns every product with S into a cross product with s. Symmetric blocks are
// summed as upper triangles in one flat array (TermSums) and expanded once per pass:
// ~45% fewer operations per term than full Eigen 3x3 / 6x6 products (measured on
// bench_registration: a linearization pass over 6167 points 0.30 -> XXX ms, 2026-12-01).
#include <Eigen/Core>

#include "mapdelta/common/registration/gicp.hpp"

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

// Inverse of a symmetric positive definite 3x3 matrix by cofactors.
inline Sym3 InverseSymmetric3(const Sym3& C) {
  const double A00 = C.yy * C.zz - C.yz * C.yz, A01 = C.xz * C.yz - C.xy * C.zz,
               A02 = C.xy * C.yz - C.xz * C.yy;
  const double A11 = C.xx * C.zz - C.xz * C.xz, A12 = C.xy * C.xz - C.xx * C.yz,
               A22 = C.xx * C.yy - C.xy * C.xy;
  const double inv_det = 1.0 / (C.xx * A00 + C.xy * A01 + C.xz * A02);
  return {A00 * inv_det, A01 * inv_det, A02 * inv_det,
          A11 * inv_det, A12 * inv_det, A22 * inv_det};
}

// The source-frame weight W' = (R^T C_t R + C_s)^-1; Rt = R^T. Plain scalar loops: Eigen's
// 3x3 products here compiled (GCC 12, SSE2) to scalar stores read back as packets, a
// store-forwarding stall per product; and C.noalias() += Rt * Ct.cast<double>() *
// Rt.transpose() came out wrong by ~1e-9 relative in some -O3 inlining contexts (caught by
// test_gicp_internals).
inline Sym3 SourceFrameWeight(const Eigen::Matrix3d& Rt, const Eigen::Matrix3f& Ct,
                              const Eigen::Matrix3f& Cs) {
  double RtC[3][3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      RtC[i][j] = Rt(i, 0) * Ct(0, j) + Rt(i, 1) * Ct(1, j) + Rt(i, 2) * Ct(2, j);
    }
  }
  auto entry = [&](int i, int j) {
    return RtC[i][0] * Rt(j, 0) + RtC[i][1] * Rt(j, 1) + RtC[i][2] * Rt(j, 2) + Cs(i, j);
  };
  return InverseSymmetric3(
      {entry(0, 0), entry(0, 1), entry(0, 2), entry(1, 1), entry(1, 2), entry(2, 2)});
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

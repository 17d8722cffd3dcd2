// common/lie.hpp against independent oracles: Eigen's AngleAxis for Exp/Log (small angles, pi),
// the cross product for Skew, central differences for the right Jacobian and for the jets a
// Ceres autodiff cost sees, and the defining identities of the pseudo-inverse.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>

#include "mapdelta/common/lie.hpp"

namespace mapdelta {
namespace {

Eigen::Vector3d AxisAngle(const Eigen::Vector3d& axis, double angle) {
  return axis.normalized() * angle;
}

TEST(Lie, SkewIsTheCrossProduct) {
  const Eigen::Vector3d v(0.3, -1.2, 2.5), w(-0.7, 0.4, 1.1);
  EXPECT_LT((Skew(v) * w - v.cross(w)).norm(), 1e-15);
  EXPECT_LT((Skew(v) + Skew(v).transpose()).norm(), 1e-15);
}

TEST(Lie, ExpAndLogAgreeWithAngleAxisFromTinyAnglesToPi) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  for (double angle : {0.0, 1e-12, 1e-9, 1e-6, 1e-3, 0.5, 2.0, M_PI - 1e-9, M_PI}) {
    const Eigen::Vector3d phi = AxisAngle(axis, angle);
    const Eigen::Quaterniond q = ExpQuaternion(phi);
    const Eigen::Quaterniond oracle(Eigen::AngleAxisd(angle, axis));
    EXPECT_LT(q.angularDistance(oracle), 1e-12) << angle;
    EXPECT_NEAR(q.norm(), 1.0, 1e-15) << angle;
    const Eigen::Vector3d back = LogQuaternion(q);
    if (angle < M_PI - 1e-6) {
      EXPECT_LT((back - phi).norm(), 1e-9) << angle;
    } else {  // at pi, phi and -phi are the same rotation: either is right
      EXPECT_LT(std::min((back - phi).norm(), (back + phi).norm()), 1e-8) << angle;
    }
    // q and -q are the same rotation: the same Log, angle within [0, pi].
    const Eigen::Quaterniond minus_q(-q.w(), -q.x(), -q.y(), -q.z());
    EXPECT_LT((LogQuaternion(minus_q) - back).norm(), 1e-9) << angle;
    EXPECT_LE(back.norm(), M_PI + 1e-12);
  }
}

TEST(Lie, LogOfARotationJustBeyondPiTakesTheShortWay) {
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI + 0.1, axis));
  EXPECT_LT((LogQuaternion(q) - AxisAngle(-axis, M_PI - 0.1)).norm(), 1e-12);
}

// d Log(q) / d q through jets, against central differences of the double version.
TEST(Lie, LogQuaternionJetsMatchCentralDifferences) {
  using Jet = ceres::Jet<double, 4>;
  for (const Eigen::Quaterniond& q0 :
       {Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, 3).normalized())),
        Eigen::Quaterniond(Eigen::AngleAxisd(1e-7, Eigen::Vector3d(0, 1, 1).normalized())),
        Eigen::Quaterniond::Identity()}) {
    const Eigen::Quaternion<Jet> qj(Jet(q0.w(), 0), Jet(q0.x(), 1), Jet(q0.y(), 2), Jet(q0.z(), 3));
    const Eigen::Matrix<Jet, 3, 1> log = LogQuaternion<Jet>(qj);
    const double h = 1e-7;
    for (int k = 0; k < 4; ++k) {
      Eigen::Vector4d plus = q0.coeffs(), minus = q0.coeffs();  // coeffs: x, y, z, w
      const int coeff = k == 0 ? 3 : k - 1;
      plus[coeff] += h;
      minus[coeff] -= h;
      const Eigen::Vector3d numeric =
          (LogQuaternion(Eigen::Quaterniond(plus)) - LogQuaternion(Eigen::Quaterniond(minus))) /
          (2 * h);
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(log[i].v[k], numeric[i], 1e-6)
            << "angle " << 2 * std::acos(q0.w()) << ", d/d coefficient " << k;
      }
    }
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(log[i].a, LogQuaternion(q0)[i], 1e-15);
  }
}

// Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d), column by column, at a tiny and at a large angle.
TEST(Lie, RightJacobianMatchesCentralDifferencesAndItsInverse) {
  for (const Eigen::Vector3d& phi :
       {Eigen::Vector3d(1e-7, -2e-7, 5e-8), Eigen::Vector3d(0.4, -1.1, 0.9)}) {
    const Eigen::Matrix3d Jr = RightJacobianSO3(phi);
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(k);
      const Eigen::Vector3d numeric =
          (LogQuaternion(ExpQuaternion(phi).conjugate() * ExpQuaternion(phi + d)) -
           LogQuaternion(ExpQuaternion(phi).conjugate() * ExpQuaternion(phi - d))) /
          (2 * h);
      EXPECT_LT((Jr.col(k) - numeric).norm(), 1e-8) << phi.transpose() << ", column " << k;
    }
    EXPECT_LT((RightJacobianInvSO3(phi) * Jr - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  }
}

TEST(Lie, PseudoInverseLeavesOutTheDirectionsBelowTheCutoff) {
  const Eigen::Matrix3d U =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  const Eigen::Matrix3d A = U * Eigen::Vector3d(4, 1, 0).asDiagonal() * U.transpose();
  const Eigen::MatrixXd pinv = PseudoInverse(A, {1e-9, 0});
  EXPECT_LT((A * pinv * A - A).norm(), 1e-12);
  EXPECT_LT((pinv * A * pinv - pinv).norm(), 1e-12);
  EXPECT_LT((pinv * U.col(2)).norm(), 1e-12);  // the null direction stays null
  // A relative cut-off of half the largest eigenvalue keeps the strongest direction only.
  const Eigen::MatrixXd strongest = PseudoInverse(A, {0, 0.5});
  EXPECT_LT((strongest - U.col(0) * U.col(0).transpose() / 4).norm(), 1e-12);
  // Full rank: the inverse.
  const Eigen::Matrix3d B = A + Eigen::Matrix3d::Identity();
  EXPECT_LT((PseudoInverse(B, {1e-9, 0}) - B.inverse()).norm(), 1e-12);
}

}  // namespace
}  // namespace mapdelta

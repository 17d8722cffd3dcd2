// The GICP residual Jacobian against central numeric differences, and the tangent helpers.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/registration/gicp_factor.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"

namespace mapdelta {
namespace {

SE3 RandomPose(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  Vector6d d;
  for (int k = 0; k < 6; ++k) d(k) = n(rng);
  d.tail<3>() *= 10;
  return RetractRight(SE3::Identity(), d);
}

TEST(GicpJacobian, MatchesNumericDifferences) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0, 5);
  for (int trial = 0; trial < 50; ++trial) {
    const SE3 T = RandomPose(rng);
    const Eigen::Vector3d s(n(rng), n(rng), n(rng)), t(n(rng), n(rng), n(rng));
    Eigen::Matrix<double, 3, 6> J;
    GicpResidual(t, s, T, &J);
    Eigen::Matrix<double, 3, 6> numeric;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Vector6d d = Vector6d::Zero();
      d(k) = h;
      const Eigen::Vector3d plus = GicpResidual(t, s, RetractRight(T, d), nullptr);
      const Eigen::Vector3d minus = GicpResidual(t, s, RetractRight(T, -d), nullptr);
      numeric.col(k) = (plus - minus) / (2 * h);
    }
    EXPECT_LT((J - numeric).cwiseAbs().maxCoeff(), 1e-6 * (1 + s.norm())) << "analytic\n"
                                                                          << J << "\nnumeric\n"
                                                                          << numeric;
  }
}

TEST(GicpJacobian, TangentRoundTrip) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const SE3 a = RandomPose(rng), b = RandomPose(rng);
    const Vector6d d = LocalRight(a, b);
    const SE3 back = RetractRight(a, d);
    EXPECT_LT((back.matrix() - b.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(GicpJacobian, PlaneRegularizationKeepsNormal) {
  // Points spread on the plane z = 0.5 x: the normal gets eigenvalue 1e-3, others 1.
  Eigen::Matrix3d sample = Eigen::Matrix3d::Zero();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), 0);
    const Eigen::Vector3d q(p.x(), p.y(), 0.5 * p.x());
    sample += q * q.transpose();
  }
  const Eigen::Matrix3d C = RegularizePlaneCovariance(sample / 100);
  const Eigen::Vector3d normal = Eigen::Vector3d(-0.5, 0, 1).normalized();
  EXPECT_NEAR(normal.dot(C * normal), kPlaneNormalEigenvalue, 1e-9);
  EXPECT_NEAR(C.trace(), 2 + kPlaneNormalEigenvalue, 1e-9);
}

}  // namespace
}  // namespace mapdelta

namespace mapdelta {
namespace {

// NeighborIndex::NearestWithin (added for GICP's bounded correspondence search) against brute
// force: the nearest point if strictly closer than the bound, else nothing.
TEST(NearestWithin, MatchesBruteForce) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> u(-10, 10);
  PointCloud cloud(2000);
  for (auto& p : cloud) p = Point(u(rng), u(rng), u(rng));
  const NeighborIndex index(cloud);
  for (int q = 0; q < 500; ++q) {
    const Point query(u(rng), u(rng), u(rng));
    const float bound = 0.2f + 0.002f * q;
    float best = std::numeric_limits<float>::infinity();
    for (const auto& p : cloud) best = std::min(best, (p - query).norm());
    size_t i = 0;
    float d = 0;
    const bool found = index.NearestWithin(query, bound, &i, &d);
    EXPECT_EQ(found, best < bound) << "bound " << bound << " nearest " << best;
    if (found) {
      EXPECT_NEAR(d, best, 1e-5);
      EXPECT_NEAR((cloud[i] - query).norm(), best, 1e-5);
    }
  }
  size_t i = 0;
  float d = 0;
  EXPECT_FALSE(index.NearestWithin(cloud[0], 0.f, &i, &d));
  EXPECT_FALSE(index.NearestWithin(cloud[0], std::numeric_limits<float>::quiet_NaN(), &i, &d));
}

}  // namespace
}  // namespace mapdelta

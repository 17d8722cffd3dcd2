// GICP's internal search structures and sums against brute force and the textbook
// formulation: the k-d tree, the correspondence cache (exact under motion), the sorted-cell
// block sweep and the source-frame linearization.
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <limits>
#include <random>
#include <set>

#include "correspondence_cache.hpp"
#include "kd_tree.hpp"
#include "linearization.hpp"
#include "mapdelta/common/registration/gicp_factor.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "sorted_cells.hpp"

namespace mapdelta::detail {
namespace {

PointCloud RandomCloud(size_t n, float half_extent, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-half_extent, half_extent);
  PointCloud cloud(n);
  for (auto& p : cloud) p = Point(u(rng), u(rng), 0.3f * u(rng));
  return cloud;
}

// Squared distances from q to every point, sorted.
std::vector<float> SortedDistances(const PointCloud& cloud, const Point& q) {
  std::vector<float> d;
  for (const auto& p : cloud) d.push_back((p - q).squaredNorm());
  std::sort(d.begin(), d.end());
  return d;
}

TEST(KdTree, MatchesBruteForce) {
  std::mt19937 rng(5);
  const PointCloud cloud = RandomCloud(3000, 10, rng);
  const KdTree tree(cloud);
  const PointCloud queries = RandomCloud(300, 12, rng);
  for (size_t q = 0; q < queries.size(); ++q) {
    const std::vector<float> d = SortedDistances(cloud, queries[q]);
    const float bound = 0.1f + 0.01f * static_cast<float>(q);
    size_t i = 0;
    float dist = 0;
    const bool found = tree.NearestWithin(queries[q], bound, &i, &dist);
    ASSERT_EQ(found, d[0] < bound * bound);
    if (found) {
      EXPECT_FLOAT_EQ((cloud[i] - queries[q]).squaredNorm(), d[0]);
    }
    {
      uint32_t two[2];
      float d2[2];
      tree.TwoNearestWithin(queries[q], bound, two, d2);
      for (int k = 0; k < 2; ++k) {
        if (d[k] < bound * bound) {
          ASSERT_NE(two[k], KdTree::kNone);
          EXPECT_FLOAT_EQ(d2[k], d[k]);
          EXPECT_FLOAT_EQ((cloud[two[k]] - queries[q]).squaredNorm(), d[k]);
        } else {
          EXPECT_EQ(two[k], KdTree::kNone);
          EXPECT_EQ(d2[k], bound * bound);
        }
      }
      const std::vector<size_t> knn = tree.KNearest(queries[q], 20);
      ASSERT_EQ(knn.size(), 20u);
      for (size_t k = 0; k < knn.size(); ++k) {
        EXPECT_FLOAT_EQ((cloud[knn[k]] - queries[q]).squaredNorm(), d[k]);
      }
    }
  }
  EXPECT_FALSE(KdTree(PointCloud{}).NearestWithin(Point::Zero(), 1.f, nullptr, nullptr));
  size_t i = 0;
  float dist = 0;
  EXPECT_FALSE(tree.NearestWithin(cloud[0], 0.f, &i, &dist));
  EXPECT_FALSE(tree.NearestWithin(cloud[0], std::numeric_limits<float>::quiet_NaN(), &i, &dist));
}

// Source points drift by steps from large to tiny (as GICP's poses do); every answer must be
// the brute-force nearest within the radius.
TEST(CorrespondenceCache, ExactUnderMotion) {
  std::mt19937 rng(9);
  const PointCloud target = RandomCloud(2000, 10, rng);
  const KdTree tree(target);
  PointCloud source = RandomCloud(500, 11, rng);
  constexpr float kMax = 1.0f;
  CorrespondenceCache cache(source.size(), kMax);
  std::normal_distribution<float> n(0, 1);
  for (int pass = 0; pass < 12; ++pass) {
    const float step = pass == 0 ? 0.f : 0.5f * std::pow(0.3f, static_cast<float>(pass));
    const Point shift(step * n(rng), step * n(rng), step * n(rng));
    for (size_t i = 0; i < source.size(); ++i) {
      source[i] += shift + Point(n(rng), n(rng), n(rng)) * (0.1f * step);
      float best = std::numeric_limits<float>::infinity();
      for (const auto& p : target) best = std::min(best, (p - source[i]).norm());
      float distance = -1;
      const uint32_t j = cache.Find(i, source[i], i > 0 ? i - 1 : CorrespondenceCache::kNone,
                                    target, tree, &distance);
      if (best < kMax) {
        ASSERT_NE(j, CorrespondenceCache::kNone) << "pass " << pass << " point " << i;
        EXPECT_NEAR(distance, best, 1e-6f);
        EXPECT_NEAR((target[j] - source[i]).norm(), best, 1e-6f);
      } else {
        EXPECT_EQ(j, CorrespondenceCache::kNone) << "pass " << pass << " point " << i;
      }
    }
  }
  // The small late steps were answered from the cache.
  EXPECT_LT(cache.searches(), 12 * source.size() / 2);
}

TEST(SortedCells, BlocksMatchBruteForce) {
  std::mt19937 rng(3);
  const PointCloud cloud = RandomCloud(1500, 5, rng);
  const double cell = 0.7;
  const Eigen::Vector3d origin(0.3, -0.2, 0.1);
  const SortedCells cells(cloud, origin, cell, 2);
  auto coords = [&](const Point& p) {
    return Eigen::Vector3i(((p.cast<double>() - origin) / cell).array().floor().cast<int>());
  };
  std::vector<uint32_t> all(cells.size());
  for (size_t c = 0; c < cells.size(); ++c) all[c] = static_cast<uint32_t>(c);
  for (int radius : {1, 2}) {
    std::vector<std::set<uint32_t>> found(cells.size());
    cells.ForEachInBlock(all, radius, [&](size_t c, size_t nb) {
      for (const uint32_t* i = cells.PointsBegin(nb); i != cells.PointsEnd(nb); ++i) {
        found[c].insert(*i);
      }
    });
    for (size_t i = 0; i < cloud.size(); i += 7) {
      std::set<uint32_t> expected;
      for (size_t j = 0; j < cloud.size(); ++j) {
        if ((coords(cloud[j]) - coords(cloud[i])).cwiseAbs().maxCoeff() <= radius) {
          expected.insert(static_cast<uint32_t>(j));
        }
      }
      EXPECT_EQ(found[cells.CellOf(i)], expected) << "point " << i << " radius " << radius;
    }
  }
}

// The closed-form plane regularization against Eigen's full eigen decomposition, for planes,
// strips, lines and blobs: eigenvalues (1e-3, 1, 1) along the same directions.
TEST(PlaneRegularization, MatchesEigenDecomposition) {
  std::mt19937 rng(29);
  std::normal_distribution<double> n(0, 1);
  const std::vector<Eigen::Vector3d> shapes = {{1, 1, 1e-4}, {1, 0.05, 1e-3}, {1, 1e-3, 1e-3},
                                               {1, 1e-9, 0}, {1, 0.7, 0.5},   {1, 1, 1}};
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Matrix3d Q = Eigen::Matrix3d::Identity();
    for (int k = 0; k < 9; ++k) Q(k / 3, k % 3) = n(rng);
    Q = Eigen::HouseholderQR<Eigen::Matrix3d>(Q).householderQ();
    const Eigen::Vector3d shape = shapes[trial % shapes.size()] * std::exp(3 * n(rng));
    const Eigen::Matrix3d A = Q * shape.asDiagonal() * Q.transpose();
    const Eigen::Matrix3d C = RegularizePlaneCovariance(A);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> of_c(C);
    EXPECT_NEAR(of_c.eigenvalues()(0), kPlaneNormalEigenvalue, 1e-9);
    EXPECT_NEAR(of_c.eigenvalues()(1), 1.0, 1e-9);
    EXPECT_NEAR(of_c.eigenvalues()(2), 1.0, 1e-9);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> of_a(A);
    const Eigen::Vector3d values = of_a.eigenvalues();
    if (values(1) - values(0) > 1e-3 * values(2)) {  // a defined normal: the same one
      const Eigen::Vector3d normal = of_a.eigenvectors().col(0);
      EXPECT_NEAR(normal.dot(C * normal), kPlaneNormalEigenvalue, 1e-9) << "trial " << trial;
    }
  }
}

TEST(Linearization, MatchesTextbookGicpTerms) {
  std::mt19937 rng(17);
  std::normal_distribution<double> n(0, 1);
  Vector6d d;
  for (int k = 0; k < 6; ++k) d(k) = n(rng);
  const SE3 T = RetractRight(SE3::Identity(), d);
  TermSums fast_sums;
  Linearization textbook;
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d s(3 * n(rng), 3 * n(rng), n(rng)), t(3 * n(rng), 3 * n(rng), n(rng));
    // Plane normals, and now and then an isotropic point (zero normal).
    Eigen::Vector3f nt(n(rng), n(rng), n(rng)), ns(n(rng), n(rng), n(rng));
    nt = trial % 7 == 3 ? Eigen::Vector3f::Zero() : Eigen::Vector3f(nt.normalized());
    ns = trial % 5 == 1 ? Eigen::Vector3f::Zero() : Eigen::Vector3f(ns.normalized());
    const Eigen::Matrix3d Ct = PlaneCovariance(nt.cast<double>());
    const Eigen::Matrix3d Cs = PlaneCovariance(ns.cast<double>());
    // Textbook: J^T W J with W = (Ct + R Cs R^T)^-1 in the target frame.
    Eigen::Matrix<double, 3, 6> J;
    const Eigen::Vector3d r = GicpResidual(t, s, T, &J);
    const Eigen::Matrix3d W = GicpWeight(Ct, Cs, T.linear());
    const Vector6d g = J.transpose() * W * r;
    textbook.H += J.transpose() * W * J;
    textbook.b += g;
    textbook.B += g * g.transpose();
    textbook.error += r.dot(W * r);
    // Source frame.
    const Eigen::Matrix3d Rt = T.linear().transpose();
    AddTerm(s, Rt * r, SourceFrameWeight(Rt, nt, ns), 0.0, &fast_sums);
  }
  const Linearization fast = Expand(fast_sums);
  const double scale = textbook.H.cwiseAbs().maxCoeff();
  EXPECT_LT((fast.H - textbook.H).cwiseAbs().maxCoeff(), 1e-9 * scale);
  EXPECT_LT((fast.b - textbook.b).cwiseAbs().maxCoeff(), 1e-9 * scale);
  EXPECT_LT((fast.B - textbook.B).cwiseAbs().maxCoeff(), 1e-9 * textbook.B.cwiseAbs().maxCoeff());
  EXPECT_NEAR(fast.error, textbook.error, 1e-9 * textbook.error);
}

// A source point taken as exact: W' = R^T (C_t + e I)^-1 R, e the plane normal eigenvalue.
TEST(Linearization, PointToPlaneWeightIsTheTargetPlaneAlone) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Vector6d d;
    for (int k = 0; k < 6; ++k) d(k) = n(rng);
    const Eigen::Matrix3d R = RetractRight(SE3::Identity(), d).linear();
    Eigen::Vector3f nt(n(rng), n(rng), n(rng));
    nt = trial % 7 == 3 ? Eigen::Vector3f::Zero() : Eigen::Vector3f(nt.normalized());
    const Eigen::Matrix3d Ct = PlaneCovariance(nt.cast<double>());
    const Eigen::Matrix3d expected =
        R.transpose() * (Ct + kPlaneNormalEigenvalue * Eigen::Matrix3d::Identity()).inverse() * R;
    const Eigen::Matrix3d fast = PointToPlaneWeight(R.transpose(), nt).Full();
    EXPECT_LT((fast - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff())
        << "trial " << trial;
  }
  // Along the target normal a point weighs as much as two aligned planes do: 1 / (2e).
  const Eigen::Vector3f up(0, 0, 1);
  EXPECT_NEAR(PointToPlaneWeight(Eigen::Matrix3d::Identity(), up).zz,
              SourceFrameWeight(Eigen::Matrix3d::Identity(), up, up).zz, 1e-6);
}

}  // namespace
}  // namespace mapdelta::detail

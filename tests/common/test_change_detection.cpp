// Paper Alg. 1-3 and metrics: brute-force oracles, a hand-counted case, and a box world with
// one building removed and one added, seen by keyframes rendered from exact depth.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "box_scene.hpp"
#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/depth_cloud.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/metrics.hpp"
#include "mapdelta/common/neighbor_index.hpp"

namespace mapdelta {
namespace {

using testing::Box;

double BruteNearest(const Point& p, const PointCloud& cloud) {
  double best = INFINITY;
  for (const auto& q : cloud) best = std::min(best, static_cast<double>((p - q).norm()));
  return best;
}

TEST(NeighborIndex, AnyWithinAgreesWithBruteForce) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> coord(0, 20);
  PointCloud cloud(4000), queries(500);
  for (auto& p : cloud) p = {coord(rng), coord(rng), coord(rng)};
  for (auto& p : queries) p = {coord(rng) * 1.5f, coord(rng), coord(rng)};
  const NeighborIndex index(cloud);
  for (const float radius : {0.3f, 1.0f}) {
    for (const auto& q : queries) {
      const double d = BruteNearest(q, cloud);
      EXPECT_EQ(index.AnyWithin(q, radius), d <= radius);
      EXPECT_EQ(index.AnyWithin(q, radius, false), d < radius);
    }
  }
  const PointCloud empty_cloud;
  EXPECT_TRUE(index.AnyWithin(cloud[7], 0.f));          // inclusive: the point itself
  EXPECT_FALSE(index.AnyWithin(cloud[7], 0.f, false));  // strict: nothing closer than 0
  EXPECT_FALSE(NeighborIndex(empty_cloud).AnyWithin(Point(0, 0, 0), 100.f));
}

// Back-projected rendered depth lands on the box surfaces and projects back to its pixel.
TEST(DepthToCloud, RenderedBoxDepthLandsOnTheSurfaceAndProjectsBack) {
  const testing::BoxWorld world = testing::MakeBoxWorld();
  const Keyframe& keyframe = world.keyframes.keyframes[5];
  const PinholeCamera& camera = world.keyframes.camera;
  const PointCloud cloud = DepthToCloud(camera, keyframe.depth, keyframe.T_map_cam, 50.0);
  ASSERT_GT(cloud.size(), 10000u);
  for (const Point& p : cloud) {
    double best = INFINITY;  // distance to the nearest face of the nearest box
    for (const Box& box : world.changed) {
      const Eigen::Vector3d q = p.cast<double>();
      const Eigen::Vector3d outside = (box.min - q).cwiseMax(q - box.max).cwiseMax(0.0);
      const double inside = std::min((q - box.min).minCoeff(), (box.max - q).minCoeff());
      best = std::min(best, outside.norm() > 0 ? outside.norm() : std::max(inside, 0.0));
    }
    ASSERT_LT(best, 1e-3) << p.transpose();
    const Eigen::Vector3d p_cam = keyframe.T_map_cam.inverse() * p.cast<double>();
    const double u = camera.fx * p_cam.x() / p_cam.z() + camera.cx;  // back on an integer pixel
    const double v = camera.fy * p_cam.y() / p_cam.z() + camera.cy;
    ASSERT_NEAR(u, std::round(u), 1e-2);
    ASSERT_NEAR(v, std::round(v), 1e-2);
  }
  size_t valid = 0;
  for (float d : keyframe.depth.depth_m) valid += d > 0 && d < 50 ? 1 : 0;
  EXPECT_EQ(cloud.size(), valid);
  EXPECT_THROW(DepthToCloud(camera, DepthImage(3, 3), SE3::Identity(), 50.0), Error);
}

TEST(ChangeDetection, AlgorithmsOneAndTwoAgreeWithBruteForce) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> coord(0, 30);
  PointCloud prior(3000), global(2000);
  for (auto& p : prior) p = {coord(rng), coord(rng), coord(rng)};
  for (auto& p : global) p = {coord(rng) + 10, coord(rng), coord(rng)};
  const double th = 1.5;
  const ObservedArea nothing(0.8);
  const PointCloud observed_prior = ObservedPriorCloud(prior, global, nothing, th, 2);
  PointCloud expected_observed;
  for (const auto& p : prior) {
    if (BruteNearest(p, global) <= th) expected_observed.push_back(p);
  }
  ASSERT_EQ(observed_prior, expected_observed);
  const Changes changes = ClassifyChanges(global, observed_prior, th, 2);
  size_t expected_new = 0, expected_removed = 0;
  for (const auto& p : global) expected_new += BruteNearest(p, observed_prior) >= th ? 1 : 0;
  for (const auto& p : observed_prior) expected_removed += BruteNearest(p, global) >= th ? 1 : 0;
  EXPECT_EQ(changes.new_points.size(), expected_new);
  EXPECT_EQ(changes.removed_points.size(), expected_removed);
  EXPECT_GT(expected_new, 100u);
  // Empty observed prior: every global point is new, nothing removed.
  const Changes all_new = ClassifyChanges(global, {}, th, 2);
  EXPECT_EQ(all_new.new_points.size(), global.size());
  EXPECT_TRUE(all_new.removed_points.empty());
}

// Hand-counted: th_ch = 1, nothing in A_obs, so observation is by distance to P_g only.
//   original O = x in {0, 10, 20, 30};  changed C = x in {0, 10, 50, 60}
//   GT new = {50, 60}, GT removed = {20, 30}
//   P_g = {0, 10, 50.3, 20.5, 100}: observed GT new = {50}, observed GT removed = {20}
//   detected new N = {50.3, 100}: TP 1 of 2 -> P_new = 1/2; {50} found -> R_new = 1
//   detected removed R = {20.2, 30, 70}: TP 1 of 3 -> P_rm = 1/3; {20} found -> R_rm = 1
TEST(Metrics, HandCountedTinyCase) {
  const auto x = [](std::initializer_list<float> xs) {
    PointCloud c;
    for (float v : xs) c.emplace_back(v, 0.f, 0.f);
    return c;
  };
  const PointCloud original = x({0, 10, 20, 30}), changed = x({0, 10, 50, 60});
  const PointCloud global = x({0, 10, 50.3f, 20.5f, 100}), detected_new = x({50.3f, 100});
  const PointCloud detected_removed = x({20.2f, 30, 70});
  const ObservedArea nothing(0.8);
  MetricsParams params;
  params.th_ch_m = 1.0;
  params.rho_p_m = 0.01;
  const ChangeMetrics m = EvaluateChangesPaper(
      {original, changed, detected_new, detected_removed, global, nothing}, params);
  EXPECT_EQ(m.gt_new, 2u);
  EXPECT_EQ(m.gt_removed, 2u);
  EXPECT_EQ(m.gt_new_observed, 1u);
  EXPECT_EQ(m.gt_removed_observed, 1u);
  EXPECT_DOUBLE_EQ(m.recall_new, 1.0);
  EXPECT_DOUBLE_EQ(m.precision_new, 0.5);
  EXPECT_DOUBLE_EQ(m.recall_removed, 1.0);
  EXPECT_DOUBLE_EQ(m.precision_removed, 1.0 / 3.0);
  // Reference variant: removed GT observed only through A_obs (empty here), so R_rm is undefined,
  // and the outlier filter (16 neighbours within 4 m) drops every isolated detection.
  const ChangeMetrics v = EvaluateChangesReferenceVariant(
      {original, changed, detected_new, detected_removed, global, nothing}, params);
  EXPECT_EQ(v.gt_removed_observed, 0u);
  EXPECT_TRUE(std::isnan(v.recall_removed));
  EXPECT_EQ(v.detected_new, 0u);
}

TEST(Metrics, RadiusOutlierFilterCountsOtherPoints) {
  PointCloud cloud;
  for (int i = 0; i < 17; ++i) cloud.emplace_back(0.1f * i, 0.f, 0.f);  // 16 others within 4 m
  cloud.emplace_back(50.f, 0.f, 0.f);
  EXPECT_EQ(RadiusOutlierFilter(cloud, 4.0, 16, 2).size(), 17u);
  EXPECT_EQ(RadiusOutlierFilter(cloud, 4.0, 17, 2).size(), 0u);
}

TEST(ChangeDetection, BoxWorldFindsRemovedAndAddedBuildings) {
  const testing::BoxWorld world = testing::MakeBoxWorld();
  const PointCloud original = testing::SampleBoxSurfaces(world.original, 0.3);
  const PointCloud changed = testing::SampleBoxSurfaces(world.changed, 0.3);
  const ChangeDetectionParams params;  // paper defaults: th_ch 3.2, rho_o 0.8, voxel 0.8
  const ChangeDetectionResult result = DetectChanges(world.keyframes, original, params);
  ASSERT_FALSE(result.changes.new_points.empty());
  ASSERT_FALSE(result.changes.removed_points.empty());
  // Every detection lies in the right building (D for new, B for removed), with th_ch slack.
  for (const auto& p : result.changes.new_points) {
    EXPECT_TRUE(p.x() > 11 - 3.2 && p.y() > 11 - 3.2) << p.transpose();
  }
  for (const auto& p : result.changes.removed_points) {
    EXPECT_TRUE(p.x() > 11 - 3.2 && p.y() < -11 + 3.2) << p.transpose();
  }
  const MetricsInput input{
      original,      changed,        result.changes.new_points, result.changes.removed_points,
      result.global, result.observed};
  const ChangeMetrics m = EvaluateChangesPaper(input);
  std::cout << "paper: R_new " << m.recall_new << " P_new " << m.precision_new << " R_rm "
            << m.recall_removed << " P_rm " << m.precision_removed << "\n";
  EXPECT_GE(m.recall_new, 0.95);
  EXPECT_GE(m.precision_new, 0.95);
  EXPECT_GE(m.recall_removed, 0.95);
  EXPECT_GE(m.precision_removed, 0.95);
  EXPECT_GT(m.gt_new_observed, 500u);
  EXPECT_GT(m.gt_removed_observed, 500u);
  const ChangeMetrics v = EvaluateChangesReferenceVariant(input);
  std::cout << "variant: R_new " << v.recall_new << " P_new " << v.precision_new << " R_rm "
            << v.recall_removed << " P_rm " << v.precision_removed << "\n";
  EXPECT_GE(v.recall_new, 0.9);
  EXPECT_GE(v.precision_new, 0.9);
  EXPECT_GE(v.recall_removed, 0.9);
  EXPECT_GE(v.precision_removed, 0.9);
}

TEST(ChangeDetection, AlignmentCallbackCorrectsShiftedPoses) {
  testing::BoxWorld world = testing::MakeBoxWorld();
  SE3 T_drift = SE3::Identity();
  T_drift.translation() = Eigen::Vector3d(5.0, -4.0, 0.5);  // larger than th_ch: must be undone
  for (auto& keyframe : world.keyframes.keyframes)
    keyframe.T_map_cam = T_drift * keyframe.T_map_cam;
  const PointCloud original = testing::SampleBoxSurfaces(world.original, 0.3);
  const ChangeDetectionParams params;
  const auto without = DetectChanges(world.keyframes, original, params);
  const auto with =
      DetectChanges(world.keyframes, original, params,
                    [&](const PointCloud&, const PointCloud&) { return T_drift.inverse(); });
  EXPECT_TRUE(with.T_prior_global.isApprox(T_drift.inverse()));
  // Drifted: much of the scene looks changed. Corrected: only the added building.
  size_t outside_d = 0;
  for (const auto& p : without.changes.new_points) outside_d += (p.x() > 7 && p.y() > 7) ? 0 : 1;
  EXPECT_GT(outside_d, 100u);
  for (const auto& p : with.changes.new_points)
    EXPECT_TRUE(p.x() > 7 && p.y() > 7) << p.transpose();
}

}  // namespace
}  // namespace mapdelta

// The confident free-space rules of issue 21 on small analytic scenes, each beside the paper's
// rule: a wall whose stereo depth overshoots behind it, a prior point occluded by a prior wall
// stereo could not match, confident (near) vs unconfident (far) depth pixels, and the per-point
// evidence of several keyframes.
#include <gtest/gtest.h>

#include <random>

#include "box_scene.hpp"
#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/metrics.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "wall_scene.hpp"

namespace mapdelta {
namespace {

using testing::SmallCamera;
using testing::Wall;

ObservedAreaParams PaperParams() { return testing::SmallSceneParams(); }

// The depth uncertainty of the shipped "confident" rule (sigma = 0.5e-3 d^2, 3 sigma).
ObservedAreaParams ConfidentParams() {
  ChangeDetectionParams rule;
  ApplyFreeSpaceRule("confident", &rule);
  ObservedAreaParams params = PaperParams();
  params.depth_sigma_per_m2 = rule.observed.depth_sigma_per_m2;
  params.depth_sigma_factor = rule.observed.depth_sigma_factor;
  return params;
}

// Points of a wall facing the camera at depth z (a prior map's wall), inside the image.
PointCloud WallPoints(float z) {
  PointCloud wall;
  for (float x = -0.5f * z; x <= 0.5f * z; x += 0.2f)
    for (float y = -0.4f * z; y <= 0.4f * z; y += 0.2f) wall.emplace_back(x, y, z);
  return wall;
}

// A prior wall at 20 m; stereo sees it 0.5 m too far (within 3 sigma(20.5 m) = 0.63 m, about
// the 95th percentile of the paper rig's overshoot at 20 m) or the wall is gone and stereo sees
// a building at 30 m. The paper's rule carves the wall in both cases; the confident rule only
// when the depth lies beyond the wall by more than its uncertainty.
TEST(ConfidentFreeSpace, WallWithDepthOvershootBehindItIsNotCarved) {
  const PinholeCamera camera = SmallCamera();
  const Point on_wall(0.6f, -0.4f, 20.1f);
  for (const auto& [params, rule] :
       {std::pair{PaperParams(), "paper"}, std::pair{ConfidentParams(), "confident"}}) {
    ObservedArea overshoot(0.4), removed(0.4);
    overshoot.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 20.5f), params);
    removed.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 30.f), params);
    const bool confident = std::string(rule) == "confident";
    EXPECT_EQ(overshoot.IsSeenFree(on_wall, 1), !confident) << rule;
    EXPECT_TRUE(removed.IsSeenFree(on_wall, 1)) << rule;  // 30 - 3 sigma(30) = 28.65 m > 20 m
    EXPECT_TRUE(overshoot.IsSeenFree({0.f, 0.f, 15.f}, 1)) << rule;  // well before the wall
  }
}

// Near depths are confident, far ones are not: the free part of a 45 m ray stops 3.04 m short
// (3 sigma), of a 10 m ray only 0.15 m.
TEST(ConfidentFreeSpace, ConfidentNearDepthCarvesFurtherThanAnUncertainFarOne) {
  const PinholeCamera camera = SmallCamera();
  DepthImage depth = Wall(camera, 10.f);
  for (int v = 0; v < camera.height; ++v)
    for (int u = camera.width / 2; u < camera.width; ++u) depth.at(u, v) = 45.f;  // right half far
  ObservedAreaParams params = ConfidentParams();
  params.max_depth_m = 50.0;
  ObservedArea confident(0.4), paper(0.4);
  confident.InsertKeyframe(camera, SE3::Identity(), depth, params);
  paper.InsertKeyframe(camera, SE3::Identity(), depth, PaperParams());
  const auto left = [](float z) { return Point(-0.3f * z, 0.1f * z, z); };
  const auto right = [](float z) { return Point(0.3f * z, 0.1f * z, z); };
  EXPECT_TRUE(confident.IsSeenFree(left(9.f), 1));
  EXPECT_TRUE(confident.IsSeenFree(right(30.f), 1));
  for (float z = 42.5f; z < 44.6f; z += 0.5f) {
    EXPECT_TRUE(paper.IsSeenFree(right(z), 1)) << z;
    EXPECT_FALSE(confident.IsSeenFree(right(z), 1)) << z;
  }
}

// A prior wall at 6 m that stereo could not match (no depth at all) hides a prior point at
// 12 m. The paper's th_f rays pass the wall and "observe" the hidden point; rays that stop at
// the prior's surfaces observe only the space in front of the wall.
TEST(ConfidentFreeSpace, RaysWithoutDepthStopAtPriorSurfacesAndMissOccludedPoints) {
  const PinholeCamera camera = SmallCamera();
  PointCloud prior = WallPoints(6.f);
  const Point occluded(0.5f, 0.3f, 12.f);
  prior.push_back(occluded);
  const PriorSurfaces surfaces(prior, 0.4);
  EXPECT_GT(surfaces.NumVoxels(), 100u);
  EXPECT_TRUE(surfaces.Contains({0.f, 0.f, 6.1f}));
  EXPECT_FALSE(surfaces.Contains({0.f, 0.f, 3.f}));
  ObservedArea paper(0.4), stopped(0.4);
  paper.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 0.f), PaperParams());
  stopped.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 0.f), PaperParams(), &surfaces);
  EXPECT_TRUE(paper.IsObserved(occluded));
  EXPECT_FALSE(stopped.IsObserved(occluded));
  EXPECT_FALSE(stopped.IsObserved({0.f, 0.f, 6.1f}));  // nor the unmatched wall itself
  for (float z = 1.f; z < 5.f; z += 0.5f) EXPECT_TRUE(stopped.IsObserved({0.2f * z, 0.f, z})) << z;
  // A measured depth beyond the prior wall still carves it (that is how removals are found).
  ObservedArea measured(0.4);
  measured.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 15.f), ConfidentParams(),
                          &surfaces);
  EXPECT_TRUE(measured.IsSeenFree({0.3f, 0.2f, 6.1f}, 1));
  const PriorSurfaces coarser(prior, 0.8);  // another grid than the octree's
  EXPECT_THROW(
      stopped.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 0.f), PaperParams(), &coarser),
      Error);
}

// IsSeenFree counts keyframes net of hits: one stray free ray is not two keyframes' evidence,
// and a keyframe that hit the voxel takes evidence away.
TEST(ConfidentFreeSpace, SeenFreeCountsKeyframesNetOfHits) {
  const PinholeCamera camera = SmallCamera();
  const Point p(0.f, 0.f, 8.f);
  ObservedArea area(0.4);
  area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 10.f), PaperParams());
  EXPECT_TRUE(area.IsSeenFree(p, 1));
  EXPECT_FALSE(area.IsSeenFree(p, 2));
  area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 12.f), PaperParams());
  EXPECT_TRUE(area.IsSeenFree(p, 2));
  area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 8.f), PaperParams());  // hit at p
  EXPECT_FALSE(area.IsSeenFree(p, 1));
  EXPECT_TRUE(area.IsObserved(p));
  EXPECT_FALSE(area.IsSeenFree({0.f, 0.f, 30.f}, 1));  // unknown
  EXPECT_THROW(area.IsSeenFree(p, 0), Error);
  EXPECT_THROW(area.IsSeenFree(p, 5), Error);
  ObservedAreaParams bad = ConfidentParams();
  bad.depth_sigma_per_m2 = -1.0;
  EXPECT_THROW(area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 10.f), bad), Error);
}

// The box world with the confident rule: the removed building is still found, nothing else is
// reported removed, and the named rules set what they say.
TEST(ConfidentFreeSpace, BoxWorldStillFindsTheRemovedBuilding) {
  const testing::BoxWorld world = testing::MakeBoxWorld();
  const PointCloud original = testing::SampleBoxSurfaces(world.original, 0.3);
  const PointCloud changed = testing::SampleBoxSurfaces(world.changed, 0.3);
  ChangeDetectionParams params;
  ApplyFreeSpaceRule("confident", &params);
  EXPECT_FALSE(params.free_rays_stop_at_prior);  // measured: costs recall, adds no precision
  EXPECT_EQ(params.removed_min_free_keyframes, 3);
  EXPECT_GT(params.observed.depth_sigma_per_m2, 0.0);
  const ChangeDetectionResult result = DetectChanges(world.keyframes, original, params);
  ASSERT_FALSE(result.changes.removed_points.empty());
  for (const auto& p : result.changes.removed_points) {
    EXPECT_TRUE(p.x() > 11 - 3.2 && p.y() < -11 + 3.2) << p.transpose();
  }
  const MetricsInput input{
      original,      changed,        result.changes.new_points, result.changes.removed_points,
      result.global, result.observed};
  const ChangeMetrics m = EvaluateChangesPaper(input);
  EXPECT_GE(m.recall_removed, 0.9);
  EXPECT_GE(m.precision_removed, 0.95);
  ApplyFreeSpaceRule("paper", &params);
  EXPECT_FALSE(params.free_rays_stop_at_prior);
  EXPECT_EQ(params.observed.depth_sigma_per_m2, 0.0);
  EXPECT_THROW(ApplyFreeSpaceRule("lenient", &params), Error);
}

}  // namespace
}  // namespace mapdelta

// Which global points mask a removal (issue 21, ChangeDetectionParams::removed_mask_radius_m,
// MaskingPoints): Alg. 2 keeps every prior point within th_ch of any global point; under the
// confident rule only global points that re-observe the prior (within 1.6 m of a prior point)
// do. A ghost in the depth (noise, or a van parked for that drive) inside a building that is
// gone no longer hides the building's prior points 3.2 m around it; the ground seen again still
// masks the prior points next to it. Of those, a point one keyframe saw masks only on the prior
// surface (within 0.5 m: mask_min_keyframes, mask_weak_radius_m): a stray inside a gone building
// no, a standing roof that sparse depth saw once yes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/error.hpp"
#include "wall_scene.hpp"

namespace mapdelta {
namespace {

constexpr float kCameraHeight = 12.f;
constexpr float kGoneTop = 6.f;      // a 6 m high box over x in [-5, 1], |y| <= 3: gone now
constexpr float kStandingTop = 5.f;  // a 5 m high box over x in [2, 4], |y| <= 1: still there
constexpr float kGhostZ = 3.5f;      // a 1 x 1 m slab at this height inside the gone box
constexpr float kStrayZ =
    5.f;  // a stray 1 x 1 m slab 1 m under the gone box's top: "re-observes" it

bool In(float x, float y, float x0, float x1, float half_width) {
  return x >= x0 && x <= x1 && std::abs(y) <= half_width;
}

// Ground at z = 0 every 0.2 m over [-10, 10] m, the gone box's top and sides, the standing
// box's top.
PointCloud Prior() {
  PointCloud prior;
  for (float x = -10.f; x <= 10.f + 1e-4f; x += 0.2f) {
    for (float y = -10.f; y <= 10.f + 1e-4f; y += 0.2f) {
      prior.emplace_back(x, y, 0.f);
      if (In(x, y, -5.f, 1.f, 3.f)) prior.emplace_back(x, y, kGoneTop);
      if (In(x, y, 2.f, 4.f, 1.f)) prior.emplace_back(x, y, kStandingTop);
    }
  }
  for (float z = 0.2f; z < kGoneTop; z += 0.2f) {
    for (float t = -3.f; t <= 3.f + 1e-4f; t += 0.2f) {
      prior.emplace_back(t - 2.f, -3.f, z);
      prior.emplace_back(t - 2.f, 3.f, z);
      prior.emplace_back(-5.f, t, z);
      prior.emplace_back(1.f, t, z);
    }
  }
  return prior;
}

// In a keyframe looking down from (cx, 0, kCameraHeight): the pixels that see the horizontal
// rectangle x in [x0, x1], |y| <= half_width at height z get its depth when `seen`, none (0)
// otherwise.
void PaintRectangle(const PinholeCamera& camera, float cx, float z, float x0, float x1,
                    float half_width, bool seen, Keyframe* keyframe) {
  const float d = kCameraHeight - z;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const float x = cx + d * static_cast<float>((u - camera.cx) / camera.fx);
      const float y = -d * static_cast<float>((v - camera.cy) / camera.fy);
      if (In(x, y, x0, x1, half_width)) keyframe->depth.at(u, v) = seen ? d : 0.f;
    }
  }
}

// Five keyframes 12 m up looking down, 0.5 m apart in x: the ground where the gone box stood,
// the standing box's top and a 1 x 1 m slab over x in [-2.5, -1.5] at ghost_z, seen by the
// first `ghost_keyframes` keyframes (the others see the ground through it).
KeyframeFolder DriveOver(float ghost_z = kGhostZ, int ghost_keyframes = 5) {
  KeyframeFolder keyframes;
  keyframes.camera = testing::SmallCamera();
  const PinholeCamera& camera = keyframes.camera;
  for (int k = 0; k < 5; ++k) {
    const float cx = -2.f + 0.5f * k;
    Keyframe keyframe =
        testing::DownwardKeyframe(camera, k + 1, Eigen::Vector3d(cx, 0, kCameraHeight));
    PaintRectangle(camera, cx, kStandingTop, 2.f, 4.f, 1.f, true, &keyframe);
    if (k < ghost_keyframes)
      PaintRectangle(camera, cx, ghost_z, -2.5f, -1.5f, 0.5f, true, &keyframe);
    keyframes.keyframes.push_back(keyframe);
  }
  return keyframes;
}

ChangeDetectionParams Confident(double mask_radius_m) {
  ChangeDetectionParams params;
  ApplyFreeSpaceRule("confident", &params);
  params.cloud_voxel_m = 0.4;
  params.observed = testing::SmallSceneParams();
  params.removed_mask_radius_m = mask_radius_m;
  return params;
}

struct RemovedCounts {
  int top_over_ghost = 0, gone_box = 0, low_sides = 0, other = 0;
};

RemovedCounts Count(const PointCloud& removed) {
  RemovedCounts counts;
  for (const Point& p : removed) {
    if (!In(p.x(), p.y(), -5.2f, 1.2f, 3.2f) || p.z() < 0.1f) {
      ++counts.other;
      continue;
    }
    ++counts.gone_box;
    counts.top_over_ghost += p.z() > kGoneTop - 0.5f && In(p.x(), p.y(), -3.f, -1.f, 1.f);
    counts.low_sides += p.z() < 2.f;
  }
  return counts;
}

TEST(RemovedMasking, AGhostInsideAGoneBuildingMasksItOnlyUnderThePapersTest) {
  const KeyframeFolder keyframes = DriveOver();
  const PointCloud prior = Prior();

  // Every global point masks: the ghost hides the box's top 2.5 m above it.
  const RemovedCounts all_mask =
      Count(DetectChanges(keyframes, prior, Confident(0.0)).changes.removed_points);
  EXPECT_EQ(all_mask.top_over_ghost, 0);
  EXPECT_EQ(all_mask.other, 0);

  // Only points that re-observe the prior mask: the ghost is 2.5 m or more from every prior
  // point, so the top over it is removed; the ground seen again still masks the low sides.
  const ChangeDetectionResult result = DetectChanges(keyframes, prior, Confident(1.6));
  const RemovedCounts reobserved = Count(result.changes.removed_points);
  EXPECT_GT(reobserved.top_over_ghost, 8);
  EXPECT_GT(reobserved.gone_box, all_mask.gone_box + 20);
  EXPECT_EQ(reobserved.low_sides, 0);
  EXPECT_EQ(reobserved.other, 0);  // nothing of the ground or the standing box
}

TEST(RemovedMasking, AStrayDepthSeenOnceMasksNothingUnderTheKeyframeSupport) {
  // One keyframe's stray slab 1 m under the gone box's top lies within 1.6 m of its prior
  // points, so the radius alone takes it for the box seen again and keeps the top over it.
  const KeyframeFolder keyframes = DriveOver(kStrayZ, 1);
  const PointCloud prior = Prior();
  ChangeDetectionParams radius = Confident(1.6);
  radius.mask_min_keyframes = 0;
  const RemovedCounts radius_only =
      Count(DetectChanges(keyframes, prior, radius).changes.removed_points);
  EXPECT_EQ(radius_only.top_over_ghost, 0);

  // The confident rule: a masking point needs points of two keyframes in its voxel, so the
  // stray slab masks nothing.
  ChangeDetectionParams supported = Confident(1.6);
  EXPECT_EQ(supported.mask_min_keyframes, 2);
  const ChangeDetectionResult result = DetectChanges(keyframes, prior, supported);
  const RemovedCounts counts = Count(result.changes.removed_points);
  EXPECT_GT(counts.top_over_ghost, 8);
  EXPECT_GT(counts.gone_box, radius_only.gone_box + 10);
  EXPECT_EQ(counts.low_sides, 0);  // the ground, seen by every keyframe, still masks
  EXPECT_EQ(counts.other, 0);

  // The support is the number of keyframes with a point in the voxel.
  ASSERT_EQ(result.global_support.size(), result.global.size());
  uint32_t stray_support = 0, ground_support = 0;
  for (size_t i = 0; i < result.global.size(); ++i) {
    const Point& p = result.global[i];
    if (std::abs(p.z() - kStrayZ) < 0.5f && p.x() < 0.f)
      stray_support = std::max(stray_support, result.global_support[i]);
    if (p.z() < 0.5f && In(p.x(), p.y(), -1.f, 0.f, 0.5f))
      ground_support = std::max(ground_support, result.global_support[i]);
  }
  EXPECT_EQ(stray_support, 1u);
  EXPECT_EQ(ground_support, 5u);
  supported.mask_min_keyframes = -1;
  EXPECT_THROW(DetectChanges(keyframes, prior, supported), Error);
}

// A 4 x 4 m roof 5 m high over |x|, |y| <= 2 that is still there, and the ground around it
// (prior points every 0.2 m), seen by eight keyframes 12 m up over x in [-1, 0.75]; only the
// first has depth on the roof, the others none there (sparse depth, as in the dark scene), so
// their rays without depth pass through it: seen free by 3 keyframes net of the one hit.
constexpr float kRoofTop = 5.f;

PointCloud RoofPrior() {
  PointCloud prior;
  for (float x = -8.f; x <= 8.f + 1e-4f; x += 0.2f) {
    for (float y = -8.f; y <= 8.f + 1e-4f; y += 0.2f) {
      const bool roof = In(x, y, -2.f, 2.f, 2.f);
      prior.emplace_back(x, y, roof ? kRoofTop : 0.f);
    }
  }
  return prior;
}

KeyframeFolder RoofSeenOnce() {
  KeyframeFolder keyframes;
  keyframes.camera = testing::SmallCamera();
  for (int k = 0; k < 8; ++k) {
    const float cx = -1.f + 0.25f * k;
    Keyframe keyframe =
        testing::DownwardKeyframe(keyframes.camera, k + 1, Eigen::Vector3d(cx, 0, kCameraHeight));
    PaintRectangle(keyframes.camera, cx, kRoofTop, -2.f, 2.f, 2.f, k == 0, &keyframe);
    keyframes.keyframes.push_back(keyframe);
  }
  return keyframes;
}

int RoofPoints(const PointCloud& points) {
  return static_cast<int>(std::count_if(points.begin(), points.end(),
                                        [](const Point& p) { return p.z() > kRoofTop - 0.1f; }));
}

TEST(RemovedMasking, ASurfaceSeenOnceStillMasksThePriorPointsItLiesOn) {
  const KeyframeFolder keyframes = RoofSeenOnce();
  const PointCloud prior = RoofPrior();

  // The keyframe support alone: the roof's points, one keyframe's, mask nothing, and the seven
  // keyframes whose rays crossed it report it removed.
  ChangeDetectionParams support_only = Confident(1.6);
  support_only.mask_weak_radius_m = 0.0;
  const ChangeDetectionResult unmasked = DetectChanges(keyframes, prior, support_only);
  EXPECT_GT(RoofPoints(unmasked.changes.removed_points), 50);

  // The confident rule: a point seen once still masks within 0.5 m of a prior point, where it
  // lies on the surface it re-observes.
  const ChangeDetectionParams confident = Confident(1.6);
  EXPECT_EQ(confident.mask_weak_radius_m, 0.5);
  const ChangeDetectionResult masked = DetectChanges(keyframes, prior, confident);
  EXPECT_EQ(RoofPoints(masked.changes.removed_points), 0);
  EXPECT_GT(RoofPoints(masked.global), 50);

  ChangeDetectionParams negative = confident;
  negative.mask_weak_radius_m = -0.5;
  EXPECT_THROW(DetectChanges(keyframes, prior, negative), Error);
}

TEST(RemovedMasking, OnlyWithTheFreeEvidence) {
  const KeyframeFolder keyframes = DriveOver();
  const PointCloud prior = Prior();
  // Without the per-point free evidence the distance is the only evidence: every point masks.
  ChangeDetectionParams paper = Confident(1.6);
  paper.removed_min_free_keyframes = 0;
  EXPECT_EQ(Count(DetectChanges(keyframes, prior, paper).changes.removed_points).top_over_ghost, 0);
  EXPECT_THROW(DetectChanges(keyframes, prior, Confident(-1.0)), Error);
}

TEST(RemovedMasking, MaskingPointsAreThoseNearThePriorOrOutsideItsFootprint) {
  const PointCloud prior = {{0, 0, 0}, {10, 0, 0}};
  const PointCloud global = {{0.5f, 0, 0}, {0, 1.2f, 0}, {10, 0.7f, 0}, {10, 0, 2}, {30, 0, 0}};
  // {0, 1.2, 0} and {10, 0, 2} are inside the footprint (1.6 m) but near no prior point.
  EXPECT_EQ(MaskingPoints(global, prior, 0.8, 1.6, 1), (std::vector<size_t>{0, 2, 4}));
  EXPECT_EQ(MaskingPoints(global, prior, 0.8, 0.0, 1), (std::vector<size_t>{0, 2}));
  EXPECT_EQ(MaskingPoints(global, {}, 0.8, 1.6, 1).size(), global.size());
  EXPECT_THROW(MaskingPoints(global, prior, 0.0, 1.6, 1), Error);

  // Under the keyframe support: points seen by fewer than 2 keyframes mask only within the weak
  // radius (0.5 m from the prior: yes; 0.7 m: no); 0 = support unknown, masks as before.
  const std::vector<uint32_t> once = {1, 5, 1, 1, 1}, unknown(global.size(), 0);
  EXPECT_EQ(MaskingPoints(global, prior, 0.8, 1.6, 1, {&once, 2, 0.6}), (std::vector<size_t>{0}));
  EXPECT_TRUE(MaskingPoints(global, prior, 0.8, 1.6, 1, {&once, 2, 0.0}).empty());
  EXPECT_EQ(MaskingPoints(global, prior, 0.8, 1.6, 1, {&once, 1, 0.0}),
            (std::vector<size_t>{0, 2, 4}));
  EXPECT_EQ(MaskingPoints(global, prior, 0.8, 1.6, 1, {&unknown, 2, 0.0}),
            (std::vector<size_t>{0, 2, 4}));
  const std::vector<uint32_t> too_few = {1, 5};
  EXPECT_THROW(MaskingPoints(global, prior, 0.8, 1.6, 1, {&too_few, 2, 0.6}), Error);
  EXPECT_THROW(MaskingPoints(global, prior, 0.8, 1.6, 1, {&once, 2, -1.0}), Error);
  ChangeDetectionParams confident, paper;
  ApplyFreeSpaceRule("confident", &confident);
  ApplyFreeSpaceRule("paper", &paper);
  EXPECT_EQ(confident.removed_mask_radius_m, 1.6);
  EXPECT_EQ(paper.removed_mask_radius_m, 0.0);
  EXPECT_EQ(paper.mask_weak_radius_m, 0.0);
}

}  // namespace
}  // namespace mapdelta

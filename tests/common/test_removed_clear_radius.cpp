// A removed point's clear radius and growth (issue 21, ChangeDetectionParams::
// removed_clear_radius_m, removed_grow_radius_m; removed_band.hpp): with the per-point free
// evidence on, a prior point whose voxel the keyframes saw free is removed when no global point
// lies within the clear radius, even if the ground the session did see lies within th_ch (the
// paper's Alg. 2 masks every prior point within 3.2 m of any current point); with growth, only
// when it is linked to a removal at th_ch or farther.
#include <gtest/gtest.h>

#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/error.hpp"
#include "wall_scene.hpp"

namespace mapdelta {
namespace {

constexpr float kCameraHeight = 10.f;
constexpr float kStandingTop = 5.f;  // a 5 m high box at x in [1, 3]: in the prior and still there

bool InBoxFootprint(float x, float y, float x0, float x1) {
  return x >= x0 && x <= x1 && std::abs(y) <= 1.f;
}

// Ground at z = 0 every 0.2 m over [-8, 8] m, a box of height gone_top at x in [-3, -1] (top and
// sides every 0.2 m; in the prior, gone now) and the standing box's top.
PointCloud Prior(float gone_top) {
  PointCloud prior;
  for (float x = -8.f; x <= 8.f + 1e-4f; x += 0.2f) {
    for (float y = -8.f; y <= 8.f + 1e-4f; y += 0.2f) {
      prior.emplace_back(x, y, 0.f);
      if (InBoxFootprint(x, y, -3.f, -1.f)) prior.emplace_back(x, y, gone_top);
      if (InBoxFootprint(x, y, 1.f, 3.f)) prior.emplace_back(x, y, kStandingTop);
    }
  }
  for (float z = 0.2f; z < gone_top; z += 0.2f) {  // the gone box's two long sides
    for (float x = -3.f; x <= -1.f + 1e-4f; x += 0.2f) {
      prior.emplace_back(x, -1.f, z);
      prior.emplace_back(x, 1.f, z);
    }
  }
  return prior;
}

// Five keyframes 10 m up looking down, 0.5 m apart in x: the ground where the gone box stood,
// and the standing box's top.
KeyframeFolder DriveOver() {
  KeyframeFolder keyframes;
  keyframes.camera = testing::SmallCamera();
  const PinholeCamera& camera = keyframes.camera;
  for (int k = 0; k < 5; ++k) {
    Keyframe keyframe;
    keyframe.t_ns = k + 1;
    keyframe.T_map_cam.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();  // optical axis down
    const float cx = -1.f + 0.5f * k;
    keyframe.T_map_cam.translation() = Eigen::Vector3d(cx, 0, kCameraHeight);
    keyframe.depth = testing::Wall(camera, kCameraHeight);
    const float d = kCameraHeight - kStandingTop;
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const float x = cx + d * static_cast<float>((u - camera.cx) / camera.fx);
        const float y = -d * static_cast<float>((v - camera.cy) / camera.fy);
        if (InBoxFootprint(x, y, 1.f, 3.f)) keyframe.depth.at(u, v) = d;
      }
    }
    keyframes.keyframes.push_back(keyframe);
  }
  return keyframes;
}

ChangeDetectionParams Confident(double clear_radius_m, double grow_radius_m = 0.0) {
  ChangeDetectionParams params;
  ApplyFreeSpaceRule("confident", &params);
  params.cloud_voxel_m = 0.4;
  params.observed = testing::SmallSceneParams();
  params.removed_clear_radius_m = clear_radius_m;
  params.removed_grow_radius_m = grow_radius_m;
  return params;
}

// Removed points on the gone box by height above the ground, and elsewhere.
struct RemovedCounts {
  int below_1_5 = 0, from_1_8_to_3 = 0, above_3_3 = 0, other = 0;
  float lowest = 100.f;
};

RemovedCounts Count(const PointCloud& removed) {
  RemovedCounts counts;
  for (const Point& p : removed) {
    if (!InBoxFootprint(p.x(), p.y(), -3.2f, -0.8f) || p.z() < 0.1f) {
      ++counts.other;
      continue;
    }
    counts.lowest = std::min(counts.lowest, p.z());
    if (p.z() < 1.5f) ++counts.below_1_5;
    if (p.z() > 1.8f && p.z() <= 3.f) ++counts.from_1_8_to_3;
    if (p.z() > 3.3f) ++counts.above_3_3;
  }
  return counts;
}

TEST(RemovedClearRadius, AGoneBoxOnGroundTheSessionSawIsRemovedDownToTheClearRadius) {
  const KeyframeFolder keyframes = DriveOver();
  const PointCloud prior = Prior(3.f);

  // th_ch alone (the paper's distance): every point of the 3 m box has ground within 3.2 m.
  const RemovedCounts masked =
      Count(DetectChanges(keyframes, prior, Confident(0.0)).changes.removed_points);
  EXPECT_EQ(masked.from_1_8_to_3, 0);
  EXPECT_EQ(masked.other, 0);

  const ChangeDetectionResult result = DetectChanges(keyframes, prior, Confident(1.6));
  const RemovedCounts clear = Count(result.changes.removed_points);
  EXPECT_GT(clear.from_1_8_to_3, 15);  // the box's top, 3 m above the ground seen below it
  EXPECT_EQ(clear.below_1_5, 0);       // within 1.6 m of the ground: still masked
  EXPECT_EQ(clear.other, 0);           // nothing of the ground or the standing box
  EXPECT_TRUE(result.changes.new_points.empty());
}

TEST(RemovedClearRadius, WithGrowthBandPointsNeedALinkToARemovalAtThCh) {
  const KeyframeFolder keyframes = DriveOver();
  // The 3 m box lies wholly within th_ch of the ground: no removal at th_ch to grow from.
  EXPECT_EQ(Count(DetectChanges(keyframes, Prior(3.f), Confident(1.6, 0.8)).changes.removed_points)
                .from_1_8_to_3,
            0);
  // A 6 m box: its top is removed at th_ch and its sides grow down to the clear radius.
  const RemovedCounts grown =
      Count(DetectChanges(keyframes, Prior(6.f), Confident(1.6, 0.8)).changes.removed_points);
  EXPECT_GT(grown.above_3_3, 15);
  EXPECT_GT(grown.from_1_8_to_3, 10);
  EXPECT_EQ(grown.below_1_5, 0);
  EXPECT_EQ(grown.other, 0);
  EXPECT_LT(grown.lowest, 2.1f);
}

TEST(RemovedClearRadius, NeedsTheFreeEvidenceAndStaysWithinThCh) {
  const KeyframeFolder keyframes = DriveOver();
  const PointCloud prior = Prior(3.f);
  // Without the per-point free evidence the distance is the only evidence: th_ch is kept.
  ChangeDetectionParams paper = Confident(1.6);
  paper.removed_min_free_keyframes = 0;
  EXPECT_EQ(Count(DetectChanges(keyframes, prior, paper).changes.removed_points).from_1_8_to_3, 0);

  EXPECT_THROW(DetectChanges(keyframes, prior, Confident(4.0)), Error);  // beyond th_ch 3.2 m
  EXPECT_THROW(DetectChanges(keyframes, prior, Confident(-1.0)), Error);
  EXPECT_THROW(DetectChanges(keyframes, prior, Confident(1.6, -1.0)), Error);
}

}  // namespace
}  // namespace mapdelta

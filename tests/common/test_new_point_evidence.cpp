// A new point's own voxel must not be seen free (issue 21, ChangeDetectionParams::
// new_not_seen_free): depth noise that one keyframe put where the others' rays pass is not a
// new surface; an object every keyframe sees is.
#include <gtest/gtest.h>

#include "mapdelta/common/change_detection.hpp"
#include "wall_scene.hpp"

namespace mapdelta {
namespace {

// Ground at z = 0 sampled every 0.2 m over [-10, 10] m in x and y.
PointCloud FlatGround() {
  PointCloud ground;
  for (float x = -10.f; x <= 10.f + 1e-4f; x += 0.2f)
    for (float y = -10.f; y <= 10.f + 1e-4f; y += 0.2f) ground.emplace_back(x, y, 0.f);
  return ground;
}

// Five keyframes of a camera 10 m above the ground looking down. Every keyframe sees a new
// object whose top is at z = 5 (image columns left of the centre); the first keyframe alone
// also reads 5 m on a patch right of the centre (a mismatched disparity), where the other
// four see the ground through it.
KeyframeFolder GhostAndObject() {
  KeyframeFolder keyframes;
  keyframes.camera = testing::SmallCamera();
  const PinholeCamera& camera = keyframes.camera;
  for (int k = 0; k < 5; ++k) {
    Keyframe keyframe = testing::DownwardKeyframe(camera, k + 1, Eigen::Vector3d(0, 0, 10));
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const bool rows = std::abs(v - camera.cy) < 15;
        const bool object = rows && u >= camera.cx - 40 && u <= camera.cx - 16;
        const bool ghost = k == 0 && rows && u >= camera.cx + 16 && u <= camera.cx + 40;
        if (object || ghost) keyframe.depth.at(u, v) = 5.f;
      }
    }
    keyframes.keyframes.push_back(keyframe);
  }
  return keyframes;
}

TEST(NewPointEvidence, DepthNoiseOtherKeyframesSeeThroughIsNotNew) {
  const KeyframeFolder keyframes = GhostAndObject();
  const PointCloud prior = FlatGround();
  for (const bool rule : {false, true}) {
    ChangeDetectionParams params;
    ApplyFreeSpaceRule("confident", &params);
    params.cloud_voxel_m = 0.4;
    params.observed = testing::SmallSceneParams();
    params.new_not_seen_free = rule;
    const ChangeDetectionResult result = DetectChanges(keyframes, prior, params);
    int object = 0, ghost = 0;
    for (const Point& p : result.changes.new_points) {
      ASSERT_GT(p.z(), 4.f);  // nothing on the ground is new
      (p.x() < 0 ? object : ghost) += 1;
    }
    EXPECT_GT(object, 20) << rule;  // the object stands either way
    if (rule)
      EXPECT_EQ(ghost, 0);
    else
      EXPECT_GT(ghost, 20);
    EXPECT_EQ(result.changes.removed_points.size(), 0u) << rule;  // the ground is all there
  }
  ChangeDetectionParams confident;
  ApplyFreeSpaceRule("confident", &confident);
  EXPECT_TRUE(confident.new_not_seen_free);
  ChangeDetectionParams paper;
  ApplyFreeSpaceRule("paper", &paper);
  EXPECT_FALSE(paper.new_not_seen_free);
}

}  // namespace
}  // namespace mapdelta

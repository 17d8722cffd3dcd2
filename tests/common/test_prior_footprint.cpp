// New points only within the prior's footprint (issue 21): ground seen past the edge of the
// mapped area is unmapped, not new; a new object inside the mapped area is still new.
#include <gtest/gtest.h>

#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/error.hpp"
#include "wall_scene.hpp"

namespace mapdelta {
namespace {

// Ground at z = 0 sampled every 0.2 m over x in [x0, x1], y in [y0, y1].
PointCloud Ground(float x0, float x1, float y0, float y1) {
  PointCloud ground;
  for (float x = x0; x <= x1 + 1e-4f; x += 0.2f)
    for (float y = y0; y <= y1 + 1e-4f; y += 0.2f) ground.emplace_back(x, y, 0.f);
  return ground;
}

TEST(PriorFootprint, KeepsPointsWithinTheRadiusHorizontally) {
  PointCloud prior = Ground(0.f, 20.f, 0.f, 20.f);
  for (float z = 0.f; z <= 10.f; z += 0.2f) prior.emplace_back(20.f, 10.f, z);  // a lamp post
  const PointCloud points = {
      {10.f, 10.f, 5.f},   // above the mapped ground: inside
      {10.f, 10.f, -2.f},  // below it: inside too (the test is horizontal)
      {21.f, 10.f, 0.f},   // 1 m past the edge: within 1.6 m
      {23.f, 10.f, 0.f},   // 3 m past the edge
      {10.f, 25.f, 8.f},   // 5 m past the other edge
  };
  const PointCloud kept = WithinPriorFootprint(points, prior, 1.6, 1);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_TRUE(kept[0].isApprox(points[0]));
  EXPECT_TRUE(kept[1].isApprox(points[1]));
  EXPECT_TRUE(kept[2].isApprox(points[2]));
  EXPECT_EQ(WithinPriorFootprint(points, prior, 0.0, 1).size(), points.size());  // off
  EXPECT_TRUE(WithinPriorFootprint(points, PointCloud{}, 1.6, 1).empty());       // nothing mapped
}

// A camera 10 m above the ground looks straight down and sees 16 x 12 m of it; the prior maps
// only x < 0. A 5 m tall object, 4 x 2.5 m, stands at x in [-7, -3] (in the mapped half). The
// paper's rule reports the unmapped half as new; the confident rule reports only the object.
TEST(PriorFootprint, GroundPastTheMapsEdgeIsNotNewButANewObjectInsideIs) {
  const PinholeCamera camera = testing::SmallCamera();
  KeyframeFolder keyframes;
  keyframes.camera = camera;
  Keyframe keyframe = testing::DownwardKeyframe(camera, 1, Eigen::Vector3d(0, 0, 10));
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const double x_at_top = (u - camera.cx) / camera.fx * 5.0;  // x where the ray meets z = 5
      if (x_at_top >= -7.0 && x_at_top <= -3.0 && std::abs(v - camera.cy) < 20)
        keyframe.depth.at(u, v) = 5.f;
    }
  }
  keyframes.keyframes.push_back(keyframe);
  const PointCloud prior = Ground(-10.f, 0.f, -8.f, 8.f);

  for (const char* rule : {"paper", "confident"}) {
    ChangeDetectionParams params;
    ApplyFreeSpaceRule(rule, &params);
    params.cloud_voxel_m = 0.4;
    params.observed = testing::SmallSceneParams();
    const Changes changes = DetectChanges(keyframes, prior, params).changes;
    int object = 0, past_edge = 0;
    for (const Point& p : changes.new_points) {
      if (p.z() > 4.f && p.x() < -2.f) ++object;
      if (p.x() > 3.2f && std::abs(p.z()) < 0.5f) ++past_edge;
    }
    EXPECT_GT(object, 10) << rule;
    if (std::string(rule) == "paper")
      EXPECT_GT(past_edge, 50) << rule;
    else
      EXPECT_EQ(past_edge, 0) << rule;
    EXPECT_EQ(object + past_edge, static_cast<int>(changes.new_points.size())) << rule;
  }
  ChangeDetectionParams bad;
  bad.new_footprint_radius_m = -1.0;
  EXPECT_THROW(DetectChanges(keyframes, prior, bad), Error);
}

}  // namespace
}  // namespace mapdelta

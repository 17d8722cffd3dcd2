// ObservedArea against analytic geometry: a camera facing a wall sees the space in front of
// it (ray voxels) and the wall itself, not what lies behind it or outside the frustum.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <utility>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/common/window_min.hpp"
#include "wall_scene.hpp"

namespace mapdelta {
namespace {

using testing::SmallCamera;
using testing::Wall;

ObservedAreaParams Params() { return testing::SmallSceneParams(); }

// Points well inside the frustum (|x|/z, |y|/z below the image half-angles with margin).
Point InFrustum(std::mt19937& rng, float z_min, float z_max) {
  std::uniform_real_distribution<float> z(z_min, z_max), s(-0.6f, 0.6f);
  const float zz = z(rng);
  return {s(rng) * 0.8f * zz, s(rng) * 0.6f * zz, zz};  // half-angles: 0.8 and 0.6 (tan)
}

// The strided min filter against the definition (brute force over the clipped window), on
// sparse random depth with holes, windows wider than the image, and strides 1-3.
TEST(WindowMin, NearestDepthAroundMatchesBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> depth_of(0.5f, 60.f), chance(0.f, 1.f);
  for (const auto& [w, h] : {std::pair{37, 23}, std::pair{64, 9}, std::pair{5, 40}}) {
    DepthImage depth(w, h);
    for (auto& d : depth.depth_m) {
      const float c = chance(rng);
      d = c < 0.08f ? depth_of(rng) : (c < 0.1f ? std::numeric_limits<float>::quiet_NaN() : 0.f);
    }
    for (int window : {0, 1, 4, 13, 100}) {
      for (int stride : {1, 2, 3}) {
        const std::vector<float> got = NearestDepthAround(depth, window, stride);
        const int cols = (w + stride - 1) / stride, rows = (h + stride - 1) / stride;
        ASSERT_EQ(got.size(), static_cast<size_t>(rows * cols));
        for (int v = 0; v < h; v += stride) {
          for (int u = 0; u < w; u += stride) {
            float expected = std::numeric_limits<float>::infinity();
            for (int y = std::max(0, v - window); y <= std::min(h - 1, v + window); ++y)
              for (int x = std::max(0, u - window); x <= std::min(w - 1, u + window); ++x) {
                const float d = depth.at(x, y);
                if (std::isfinite(d) && d > 0.f) expected = std::min(expected, d);
              }
            ASSERT_EQ(got[static_cast<size_t>(v / stride) * cols + u / stride], expected)
                << w << "x" << h << " window " << window << " stride " << stride << " at " << u
                << "," << v;
          }
        }
      }
    }
  }
}

TEST(ObservedArea, WallInFrontOfCameraAgreesWithGeometry) {
  const PinholeCamera camera = SmallCamera();
  ObservedArea area(0.4);
  area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 10.f), Params());
  EXPECT_GT(area.NumKnownLeaves(), 0u);
  std::mt19937 rng(17);
  for (int i = 0; i < 300; ++i) {
    const Point before = InFrustum(rng, 1.5f, 9.0f);
    EXPECT_TRUE(area.IsObserved(before)) << before.transpose();
    const Point behind = InFrustum(rng, 11.5f, 30.0f);
    EXPECT_FALSE(area.IsObserved(behind)) << behind.transpose();
  }
  EXPECT_TRUE(area.IsObserved({0.f, 0.f, 10.f}));   // the wall voxel (occupied)
  EXPECT_FALSE(area.IsObserved({0.f, 0.f, -3.f}));  // behind the camera
  EXPECT_FALSE(area.IsObserved({30.f, 0.f, 5.f}));  // outside the frustum
}

TEST(ObservedArea, FreeRaysForPixelsWithoutDepthAndBeyondMaxDepth) {
  const PinholeCamera camera = SmallCamera();
  ObservedAreaParams params = Params();
  params.max_depth_m = 50.0;
  for (const float d : {0.f, 80.f}) {  // no depth, and a depth beyond th_d
    ObservedArea area(0.4);
    area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, d), params);
    std::mt19937 rng(3);
    for (int i = 0; i < 200; ++i) {
      EXPECT_TRUE(area.IsObserved(InFrustum(rng, 1.5f, 19.0f)));
      EXPECT_FALSE(area.IsObserved(InFrustum(rng, 21.5f, 60.0f)));
    }
  }
}

TEST(ObservedArea, FreeRayStopsAtADepthBeyondMaxDepth) {
  const PinholeCamera camera = SmallCamera();
  ObservedAreaParams params = Params();
  params.max_depth_m = 10.0;  // the wall at 15 m is no hit, but the 15 m before it are free
  params.free_ray_m = 20.0;
  ObservedArea area(0.4);
  area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 15.f), params);
  std::mt19937 rng(6);
  for (int i = 0; i < 200; ++i) {
    EXPECT_TRUE(area.IsObserved(InFrustum(rng, 1.5f, 14.0f)));
    EXPECT_FALSE(area.IsObserved(InFrustum(rng, 16.5f, 30.0f)));  // not through the wall
  }
}

// A wall at 6 m with a 20x20 px hole in its depth image (as stereo leaves on textureless
// walls). The paper's rule casts th_f rays through the hole and marks the space behind the
// wall observed; the bounded rule (window wider than the hole's half-width of 10 px) ends those
// rays at the wall, a window narrower than that falls back to th_f in the hole's centre.
TEST(ObservedArea, FreeRayBoundStopsRaysThroughAHoleInAWall) {
  const PinholeCamera camera = SmallCamera();
  DepthImage depth = Wall(camera, 6.f);
  for (int v = 38; v < 58; ++v)
    for (int u = 54; u < 74; ++u) depth.at(u, v) = 0.f;  // hole: |x|/z, |y|/z < 10/80
  const auto behind_hole = [](float z) { return Point(0.05f * z, -0.04f * z, z); };  // inside
  const auto insert = [&](int window_px) {
    ObservedAreaParams params = Params();
    params.free_ray_bound_window_px = window_px;
    ObservedArea area(0.4);
    area.InsertKeyframe(camera, SE3::Identity(), depth, params);
    return area;
  };
  const ObservedArea paper = insert(0), bounded = insert(16), narrow = insert(4);
  for (float z = 8.f; z < 19.f; z += 0.5f) {
    EXPECT_TRUE(paper.IsObserved(behind_hole(z))) << z;
    EXPECT_FALSE(bounded.IsObserved(behind_hole(z))) << z;
    EXPECT_TRUE(narrow.IsObserved({0.f, 0.f, z})) << z;  // hole centre: no depth within 4 px
  }
  for (float z = 1.f; z < 5.f; z += 0.5f) {
    EXPECT_TRUE(bounded.IsObserved(behind_hole(z))) << z;  // in front of the wall: free
  }
  // Away from the hole the wall occludes in every variant.
  EXPECT_FALSE(bounded.IsObserved({3.f, 2.f, 12.f}));
  EXPECT_FALSE(paper.IsObserved({3.f, 2.f, 12.f}));
}

TEST(ObservedArea, PoseMovesTheObservedSpace) {
  const PinholeCamera camera = SmallCamera();
  SE3 T_map_cam = SE3::Identity();
  T_map_cam.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T_map_cam.translation() = Eigen::Vector3d(100, -50, 2);  // camera z axis -> map +x
  ObservedArea area(0.4);
  area.InsertKeyframe(camera, T_map_cam, Wall(camera, 10.f), Params());
  EXPECT_TRUE(area.IsObserved({105.f, -50.f, 2.f}));
  EXPECT_FALSE(area.IsObserved({95.f, -50.f, 2.f}));
  EXPECT_FALSE(area.IsObserved({115.f, -50.f, 2.f}));
}

std::vector<Point> QueryGrid() {
  std::vector<Point> q;
  for (float x = -12; x <= 12; x += 0.7f)
    for (float y = -8; y <= 8; y += 0.9f)
      for (float z = -2; z <= 24; z += 0.6f) q.emplace_back(x, y, z);
  return q;
}

TEST(ObservedArea, MergeEqualsJointInsertionAndSerializationRoundTrips) {
  const PinholeCamera camera = SmallCamera();
  SE3 second = SE3::Identity();
  second.translation() = Eigen::Vector3d(3, 0, 1);
  ObservedArea joint(0.4), a(0.4), b(0.4);
  joint.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 10.f), Params());
  joint.InsertKeyframe(camera, second, Wall(camera, 0.f), Params());
  a.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 10.f), Params());
  b.InsertKeyframe(camera, second, Wall(camera, 0.f), Params());
  a.Merge(b);
  const std::string bytes = a.SerializeBinary();
  const ObservedArea back = ObservedArea::DeserializeBinary(bytes);
  const std::string path =
      (std::filesystem::temp_directory_path() / "mapdelta_observed.bt").string();
  a.Save(path);
  const ObservedArea loaded = ObservedArea::Load(path);
  size_t known = 0;
  for (const Point& p : QueryGrid()) {
    const bool expected = joint.IsObserved(p);
    known += expected ? 1 : 0;
    ASSERT_EQ(a.IsObserved(p), expected) << p.transpose();
    ASSERT_EQ(back.IsObserved(p), expected) << p.transpose();
    ASSERT_EQ(loaded.IsObserved(p), expected) << p.transpose();
  }
  EXPECT_GT(known, 1000u);
  EXPECT_THROW(a.Merge(ObservedArea(0.8)), Error);
}

// A session's octree is stored and read back before later commits weigh its evidence: the
// .ot stream keeps each voxel's log-odds, the .bt stream only free/occupied (read back, one
// keyframe's free voxel looks seen free by four).
TEST(ObservedArea, EvidenceSurvivesTheFullStreamButNotTheBinaryOne) {
  const PinholeCamera camera = SmallCamera();
  ObservedArea once(0.4);
  once.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 10.f), Params());
  const ObservedArea full = ObservedArea::DeserializeBinary(once.SerializeEvidence());
  const ObservedArea binary = ObservedArea::DeserializeBinary(once.SerializeBinary());
  size_t free_once = 0, free_four_binary = 0;
  for (const Point& p : QueryGrid()) {
    ASSERT_EQ(full.IsObserved(p), once.IsObserved(p)) << p.transpose();
    for (int k = 1; k <= 4; ++k)
      ASSERT_EQ(full.IsSeenFree(p, k), once.IsSeenFree(p, k)) << p.transpose() << " k " << k;
    free_once += once.IsSeenFree(p, 1) && !once.IsSeenFree(p, 2);
    free_four_binary += once.IsSeenFree(p, 1) && binary.IsSeenFree(p, 4);
  }
  EXPECT_GT(free_once, 100u);
  EXPECT_GT(free_four_binary, free_once / 2);  // what the stored .bt made of one keyframe
  EXPECT_EQ(ObservedArea::DeserializeBinary(ObservedArea(0.4).SerializeEvidence()).NumKnownLeaves(),
            0u);
}

TEST(ObservedArea, RejectsBadInput) {
  const PinholeCamera camera = SmallCamera();
  ObservedArea area(0.4);
  EXPECT_THROW(area.InsertKeyframe(camera, SE3::Identity(), DepthImage(10, 10), Params()), Error);
  EXPECT_THROW(ObservedArea(0.0), Error);
  ObservedAreaParams negative_window = Params();
  negative_window.free_ray_bound_window_px = -1;
  EXPECT_THROW(area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 10.f), negative_window),
               Error);
  EXPECT_THROW(ObservedArea::Load("/nonexistent/x.bt"), Error);
  area.InsertKeyframe(camera, SE3::Identity(), Wall(camera, 10.f), Params());
  for (const std::string& good : {area.SerializeBinary(), area.SerializeEvidence()}) {
    std::mt19937 rng(99);
    for (int k = 0; k < 200; ++k) {
      const size_t cut = std::uniform_int_distribution<size_t>(0, good.size() - 1)(rng);
      EXPECT_THROW(ObservedArea::DeserializeBinary(good.substr(0, cut)), Error) << cut;
      std::string flipped = good;
      flipped[std::uniform_int_distribution<size_t>(0, good.size() - 1)(rng)] ^=
          static_cast<char>(1 + rng() % 255);
      try {
        ObservedArea::DeserializeBinary(flipped);  // a flip may leave a valid tree; never a crash
      } catch (const Error&) {
      }
    }
  }
}

}  // namespace
}  // namespace mapdelta

// Rendering against analytic geometry: rendered depth equals the ray hit on a known box,
// Embree agrees with the brute-force caster, and the stereo pair is consistent
// (a surface point seen at depth z in cam0 appears fx*B/z pixels to the left in cam1).
#include <gtest/gtest.h>

#include <cmath>

#include "mapdelta/sim/dataset_writer.hpp"
#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/random.hpp"
#include "mapdelta/sim/raycaster.hpp"
#include "mapdelta/sim/renderer.hpp"

namespace mapdelta::sim {
namespace {

Scene OneBoxScene() {
  Scene s;
  s.extent_x = s.extent_y = 100;
  s.streets.xs = {-40, 40};
  s.streets.ys = {-40, 40};
  Object o;
  o.kind = "building";
  o.material = Material::kBrick;
  o.albedo = 0.5f;
  o.boxes.push_back({Eigen::Vector3d(20, -10, 0), Eigen::Vector3d(30, 10, 15)});
  s.objects.push_back(o);
  return s;
}

PinholeCamera SmallCamera() {
  PinholeCamera cam;
  cam.width = 160;
  cam.height = 90;
  cam.fx = cam.fy = 80;
  cam.cx = 80;
  cam.cy = 45;
  return cam;
}

// Camera at (0, 0, 5) looking along +x (body yaw 0 with the dataset's extrinsics, no offset).
SE3 LookAlongX() {
  SE3 T = BodyToCam0();
  T.translation() = Eigen::Vector3d(0, 0, 5);
  return T;
}

TEST(SimRender, DepthMatchesAnalyticRayHit) {
  const Scene s = OneBoxScene();
  const EmbreeCaster caster(s);
  const PinholeCamera cam = SmallCamera();
  const SE3 T = LookAlongX();
  const RenderedView view = RenderView(s, caster, cam, T, {});
  int checked_wall = 0, checked_ground = 0;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      // Analytic: ray d = R * ((u-cx)/fx, (v-cy)/fy, 1) from (0,0,5); the wall is the plane x = 20
      // for |y| <= 10, z in [0, 15]; the ground is z = 0. Depth = ray parameter (z_cam = 1).
      const Eigen::Vector3d d =
          T.linear() * Eigen::Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1);
      const double t_wall = 20.0 / d.x();
      const Eigen::Vector3d pw = T.translation() + t_wall * d;
      const double t_ground = d.z() < 0 ? -5.0 / d.z() : INFINITY;
      double expected = 0;
      if (std::abs(pw.y()) < 9.99 && pw.z() > 0.01 && pw.z() < 14.99 && t_wall < t_ground) {
        expected = t_wall;
        ++checked_wall;
      } else if (std::isfinite(t_ground) &&
                 (std::abs(pw.y()) > 10.01 || pw.z() < -0.01 || t_ground < t_wall)) {
        expected = t_ground;
        ++checked_ground;
      } else {
        continue;  // within a hair of an edge
      }
      EXPECT_NEAR(view.depth[static_cast<size_t>(v) * cam.width + u], expected, 1e-3 * expected)
          << "pixel " << u << "," << v;
    }
  }
  EXPECT_GT(checked_wall, 2000);
  EXPECT_GT(checked_ground, 2000);
}

TEST(SimRender, EmbreeAgreesWithBruteForceOnACity) {
  SimConfig c = PresetConfig("tiny");
  const Scenes scenes = BuildScenes(c);
  const Scene& s = scenes.s1.scene;
  const EmbreeCaster fast(s);
  const BruteForceCaster slow(s);
  Rng rng(3);
  int hits = 0, mismatches = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3f o(static_cast<float>(rng.Uniform(-60, 60)),
                            static_cast<float>(rng.Uniform(-60, 60)),
                            static_cast<float>(rng.Uniform(1, 30)));
    bool inside = false;  // rays from inside a building are not a camera's case
    for (const Object& ob : s.objects) {
      for (const Box& bx : ob.boxes) inside |= bx.ContainsStrict(o.cast<double>(), -0.01);
    }
    if (inside) continue;
    const Eigen::Vector3f d(static_cast<float>(rng.Gaussian()), static_cast<float>(rng.Gaussian()),
                            static_cast<float>(rng.Gaussian()));
    Hit a, b;
    const bool ha = fast.Intersect(o, d, 0.f, 1e5f, &a), hb = slow.Intersect(o, d, 0.f, 1e5f, &b);
    ASSERT_EQ(ha, hb) << "ray " << i;
    if (!ha) continue;
    ++hits;
    EXPECT_NEAR(a.t, b.t, 1e-4f * std::max(1.f, b.t)) << "ray " << i;
    // Object and face can only differ on exact ties (edges, touching boxes).
    if (a.object != b.object || (a.normal - b.normal).norm() > 1e-3f) {
      ++mismatches;
    }
  }
  EXPECT_GT(hits, 8000);
  EXPECT_LT(mismatches, 5);
}

TEST(SimRender, StereoPairIsConsistent) {
  SimConfig c = PresetConfig("tiny");
  const Scenes scenes = BuildScenes(c);
  const SequencePlan plan = PlanSequence(c, scenes, "S1_01");
  const Scene& s = scenes.s1.scene;
  const EmbreeCaster caster(s);
  const PinholeCamera cam = SmallCamera();
  const double B = c.baseline;
  SE3 T_cam0_cam1 = SE3::Identity();
  T_cam0_cam1.translation().x() = B;
  int candidates = 0, depth_checked = 0, intensity_checked = 0;
  double abs_diff = 0;
  for (double t : {2.0, 9.0, 17.0}) {
    const SE3 T0 = plan.trajectory.Evaluate(t).T_map_body * BodyToCam0();
    const SE3 T1 = T0 * T_cam0_cam1;
    const RenderedView l = RenderView(s, caster, cam, T0, {});
    const RenderedView r = RenderView(s, caster, cam, T1, {});
    for (int v = 0; v < cam.height; ++v) {
      for (int u = 0; u < cam.width; ++u) {
        const float z = l.depth[static_cast<size_t>(v) * cam.width + u];
        if (z <= 0.f || z > 60.f) continue;
        // The left pixel's surface point, projected into cam1 by geometry alone.
        const Eigen::Vector3d p0 = cam.BackProject(u, v, z);
        const Eigen::Vector3d p1 = T1.inverse() * (T0 * p0);
        const double u1 = cam.fx * p1.x() / p1.z() + cam.cx;
        const double disparity = cam.fx * B / z;
        ASSERT_NEAR(u - u1, disparity, 1e-3 * disparity);
        // Where that lands on a pixel centre-ish and is not occluded, the right depth is z.
        const int ur = static_cast<int>(std::lround(u1));
        if (ur < 0 || ur >= cam.width || std::abs(u1 - ur) > 0.1) continue;
        const size_t ir = static_cast<size_t>(v) * cam.width + ur;
        ++candidates;
        if (std::abs(r.depth[ir] - z) > 0.05f * z) continue;  // occluded or a depth edge
        ++depth_checked;
        abs_diff += std::abs(r.intensity[ir] - l.intensity[static_cast<size_t>(v) * cam.width + u]);
        ++intensity_checked;
      }
    }
  }
  ASSERT_GT(depth_checked, 500);
  // Most points are seen by cam1 at the depth geometry predicts (the rest are occluded).
  EXPECT_GT(static_cast<double>(depth_checked) / candidates, 0.85);
  // View-independent shading: corresponding pixels have the same brightness up to texture
  // variation within the 0.1 px offset.
  EXPECT_LT(abs_diff / intensity_checked, 0.02);
}

}  // namespace
}  // namespace mapdelta::sim

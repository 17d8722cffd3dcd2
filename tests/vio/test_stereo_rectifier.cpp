// Stereo rectifier with oracles: EuRoC MH_01's distorted, non-parallel cameras (the simulator's
// euroc rig, the published calibration).
//  - Points: a 3-D point seen at rectified pixel (u, v) in cam0 must appear on the same row in
//    the rectified cam1 at disparity f*b/z (rectified pinhole model), and the rectifier's tables
//    must fetch both rectified pixels from where the radial-tangential model (written out here,
//    independent of OpenCV) projects the point in the original cameras, to < 0.1 px.
//  - Images: a textured plane rendered through the distorted cameras (rays by the simulator's
//    Newton undistortion), rectified, must equal the plane rendered directly through the
//    rectified pinhole cameras up to interpolation and 8-bit rounding.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <chrono>
#include <cmath>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/stereo_rectifier.hpp"
#include "mapdelta/sim/sensor_rig.hpp"

using namespace mapdelta;

namespace {

EurocCamera ToEuroc(const sim::SimCamera& c) {
  EurocCamera e;
  e.T_body_cam = c.T_body_cam;
  e.rate_hz = 20;
  e.intrinsics = c.K;
  e.distortion_model = "radial-tangential";
  e.distortion = {c.distortion.k1, c.distortion.k2, c.distortion.p1, c.distortion.p2};
  return e;
}

// Radial-tangential projection (Bouguet / OpenCV plumb bob), written out as the oracle.
Eigen::Vector2d ProjectDistorted(const EurocCamera& cam, const Eigen::Vector3d& p_body) {
  const Eigen::Vector3d p = cam.T_body_cam.inverse() * p_body;
  const double x = p.x() / p.z(), y = p.y() / p.z();
  const double k1 = cam.distortion[0], k2 = cam.distortion[1], p1 = cam.distortion[2],
               p2 = cam.distortion[3];
  const double r2 = x * x + y * y, radial = 1 + k1 * r2 + k2 * r2 * r2;
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {cam.intrinsics.fx * xd + cam.intrinsics.cx, cam.intrinsics.fy * yd + cam.intrinsics.cy};
}

Eigen::Vector2d ProjectPinhole(const EurocCamera& cam, const Eigen::Vector3d& p_body) {
  const Eigen::Vector3d p = cam.T_body_cam.inverse() * p_body;
  return {cam.intrinsics.fx * p.x() / p.z() + cam.intrinsics.cx,
          cam.intrinsics.fy * p.y() / p.z() + cam.intrinsics.cy};
}

struct Fixture {
  sim::SensorRig rig = sim::EurocMh01Rig();
  EurocCamera cam0 = ToEuroc(rig.cam[0]), cam1 = ToEuroc(rig.cam[1]);
};

// Smooth texture on the plane z_body = kPlaneZ (EuRoC body z = forward): periods of 0.2-0.6 m,
// i.e. 30-90 px at 3 m, so bilinear interpolation error stays far below one grey level.
constexpr double kPlaneZ = 3.0;
double Texture(double x, double y) {
  return 128 + 60 * std::sin(2 * M_PI * x / 0.23) * std::cos(2 * M_PI * y / 0.31) +
         30 * std::sin(2 * M_PI * (x + y) / 0.6);
}
double TextureAlongRay(const SE3& T_body_cam, const Eigen::Vector3d& ray_cam) {
  const Eigen::Vector3d o = T_body_cam.translation(), d = T_body_cam.linear() * ray_cam;
  const double s = (kPlaneZ - o.z()) / d.z();
  const Eigen::Vector3d p = o + s * d;
  return Texture(p.x(), p.y());
}

}  // namespace

TEST(StereoRectifier, RectifiedCamerasFormAnIdealPair) {
  Fixture f;
  ASSERT_FALSE(IsRectifiedPair(f.cam0, f.cam1));
  const StereoRectifier r(f.cam0, f.cam1);
  EXPECT_TRUE(IsRectifiedPair(r.cam0(), r.cam1()));
  EXPECT_FALSE(r.cam0().HasDistortion());
  EXPECT_DOUBLE_EQ(r.cam0().intrinsics.fx, r.cam1().intrinsics.fx);
  EXPECT_DOUBLE_EQ(r.cam0().intrinsics.cx, r.cam1().intrinsics.cx);
  EXPECT_DOUBLE_EQ(r.cam0().intrinsics.cy, r.cam1().intrinsics.cy);
  EXPECT_EQ(r.cam0().intrinsics.width, 752);
  const SE3 T01_in = f.cam0.T_body_cam.inverse() * f.cam1.T_body_cam;
  EXPECT_NEAR(r.baseline_m(), T01_in.translation().norm(), 1e-9);  // EuRoC: 0.110 m
  const SE3 T01 = r.cam0().T_body_cam.inverse() * r.cam1().T_body_cam;
  EXPECT_LT(RotationAngle(T01, SE3::Identity()), 1e-8);
  EXPECT_NEAR(T01.translation().x(), r.baseline_m(), 1e-8);
  EXPECT_LT(T01.translation().tail<2>().norm(), 1e-8);
  // Rectification only turns the cameras: optical centres stay.
  EXPECT_LT((r.cam0().T_body_cam.translation() - f.cam0.T_body_cam.translation()).norm(), 1e-12);
  EXPECT_LT((r.cam1().T_body_cam.translation() - f.cam1.T_body_cam.translation()).norm(), 1e-12);
}

TEST(StereoRectifier, TablesAgreeWithDistortedProjectionAndRowsMatch) {
  Fixture f;
  const StereoRectifier r(f.cam0, f.cam1);
  const PinholeCamera& k = r.cam0().intrinsics;
  const double disparity_per_inv_depth = k.fx * r.baseline_m();
  double worst_left = 0, worst_right = 0, worst_row = 0;
  int checked = 0;
  for (double z : {0.8, 2.5, 9.0, 40.0}) {
    for (int v = 2; v < k.height - 2; v += 12) {
      for (int u = 2; u < k.width - 2; u += 12) {
        const Eigen::Vector3d p_body = r.cam0().T_body_cam * k.BackProject(u, v, z);
        const Eigen::Vector2d right = ProjectPinhole(r.cam1(), p_body);
        worst_row = std::max(worst_row, std::abs(right.y() - v));
        EXPECT_NEAR(u - right.x(), disparity_per_inv_depth / z, 1e-6);
        const cv::Point2d src0 = r.SourcePixel(0, u, v);
        worst_left =
            std::max(worst_left,
                     (Eigen::Vector2d(src0.x, src0.y) - ProjectDistorted(f.cam0, p_body)).norm());
        if (right.x() < 0 || right.x() > k.width - 1) continue;
        const cv::Point2d src1 = r.SourcePixel(1, right.x(), right.y());
        worst_right =
            std::max(worst_right,
                     (Eigen::Vector2d(src1.x, src1.y) - ProjectDistorted(f.cam1, p_body)).norm());
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 5000);
  EXPECT_LT(worst_row, 1e-6) << "rectified rows of the same point differ";
  EXPECT_LT(worst_left, 0.1) << "cam0 table vs radial-tangential projection (px)";
  EXPECT_LT(worst_right, 0.1) << "cam1 table vs radial-tangential projection (px)";
  std::printf(
      "rectifier: f %.2f px, baseline %.4f m; worst table error cam0 %.4f px, cam1 %.4f px\n", k.fx,
      r.baseline_m(), worst_left, worst_right);
}

TEST(StereoRectifier, RectifiedImagesMatchDirectPinholeRendering) {
  Fixture f;
  const StereoRectifier r(f.cam0, f.cam1);
  const EurocCamera* inputs[2] = {&f.cam0, &f.cam1};
  const EurocCamera* rects[2] = {&r.cam0(), &r.cam1()};
  for (int i = 0; i < 2; ++i) {
    const sim::SimCamera& sc = f.rig.cam[i];
    const std::vector<Eigen::Vector3f> rays = sim::PixelRays(sc);
    cv::Mat distorted(sc.K.height, sc.K.width, CV_8UC1);
    for (int v = 0; v < sc.K.height; ++v) {
      for (int u = 0; u < sc.K.width; ++u) {
        const Eigen::Vector3f& ray = rays[static_cast<size_t>(v) * sc.K.width + u];
        ASSERT_EQ(ray.z(), 1.f);
        const double value = TextureAlongRay(inputs[i]->T_body_cam, ray.cast<double>());
        distorted.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(std::lround(value));
      }
    }
    cv::Mat rectified;
    const auto t0 = std::chrono::steady_clock::now();
    for (int rep = 0; rep < 20; ++rep) r.Rectify(i, distorted, &rectified);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() /
        20;
    const PinholeCamera& k = rects[i]->intrinsics;
    double sum = 0, worst = 0;
    int n = 0;
    for (int v = 2; v < k.height - 2; ++v) {
      for (int u = 2; u < k.width - 2; ++u) {
        const double expected = TextureAlongRay(rects[i]->T_body_cam, k.BackProject(u, v, 1.0));
        const double err = std::abs(rectified.at<uint8_t>(v, u) - expected);
        sum += err;
        worst = std::max(worst, err);
        ++n;
      }
    }
    EXPECT_LT(sum / n, 0.6) << "cam" << i << " mean grey error";
    EXPECT_LT(worst, 3.0) << "cam" << i << " worst grey error";
    std::printf(
        "cam%d rectified vs direct: mean %.3f, worst %.2f grey levels; remap %.2f ms wall\n", i,
        sum / n, worst, ms);
  }
}

TEST(StereoRectifier, RejectsWhatItCannotRectify) {
  Fixture f;
  EXPECT_EQ(MakeRectifierIfNeeded(f.cam0, f.cam1) == nullptr, false);
  // An already rectified pair needs nothing.
  const StereoRectifier r(f.cam0, f.cam1);
  EXPECT_EQ(MakeRectifierIfNeeded(r.cam0(), r.cam1()), nullptr);
  EurocCamera fisheye = f.cam0;
  fisheye.distortion_model = "equidistant";
  try {
    StereoRectifier bad(fisheye, f.cam1);
    FAIL() << "equidistant accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kUnsupported);
    EXPECT_NE(std::string(e.what()).find("equidistant"), std::string::npos) << e.what();
  }
  // cam1 above cam0: not a horizontal pair.
  EurocCamera above = f.cam1;
  above.T_body_cam.translation() = f.cam0.T_body_cam * Eigen::Vector3d(0, -0.1, 0);
  EXPECT_THROW(StereoRectifier(f.cam0, above), Error);
  cv::Mat small(10, 10, CV_8UC1, cv::Scalar(0)), out;
  EXPECT_THROW(r.Rectify(0, small, &out), Error);
}

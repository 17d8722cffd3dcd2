// Sensor rigs: the radial-tangential lens model and its Newton inverse, per-pixel rays, EuRoC
// MH_01's rig, and a short `euroc` preset sequence read back with common's EuRoC loader
// (distortion and T_BS as published, IMU in EuRoC's axes consistent with the ground truth).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/sensor_rig.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::sim {
namespace {
namespace fs = std::filesystem;

TEST(SensorRig, RadTanNewtonInverseIsExact) {
  const SensorRig rig = EurocMh01Rig();
  for (const SimCamera& cam : rig.cam) {
    double worst = 0;
    // Normalized coordinates out to the 752x480 image corners (|x| ~ 1.3 after undistortion).
    for (double x = -1.3; x <= 1.3; x += 0.05) {
      for (double y = -0.9; y <= 0.9; y += 0.05) {
        const Eigen::Vector2d p(x, y);
        Eigen::Vector2d back;
        ASSERT_TRUE(cam.distortion.Undistort(cam.distortion.Distort(p), &back)) << x << " " << y;
        worst = std::max(worst, (back - p).norm());
      }
    }
    EXPECT_LT(worst, 1e-10);
  }
  // Zero distortion is the identity.
  const RadTan none;
  EXPECT_EQ(none.Distort({0.3, -0.2}), Eigen::Vector2d(0.3, -0.2));
}

TEST(SensorRig, PixelRaysReprojectToPixelCentres) {
  const SimCamera cam = EurocMh01Rig().cam[1];
  const std::vector<Eigen::Vector3f> rays = PixelRays(cam);
  ASSERT_EQ(rays.size(), 752u * 480u);
  double worst = 0;
  for (int v = 0; v < 480; v += 7) {
    for (int u = 0; u < 752; u += 7) {
      const Eigen::Vector3f& r = rays[static_cast<size_t>(v) * 752 + u];
      ASSERT_EQ(r.z(), 1.f);
      const Eigen::Vector2d d = cam.distortion.Distort({r.x(), r.y()});
      const Eigen::Vector2d px(cam.K.fx * d.x() + cam.K.cx, cam.K.fy * d.y() + cam.K.cy);
      worst = std::max(worst, (px - Eigen::Vector2d(u, v)).norm());
    }
  }
  EXPECT_LT(worst, 1e-3);  // float storage of the rays
  // Barrel lens: the corner ray is wider than the pinhole ray through the same pixel.
  EXPECT_LT(rays[0].x(), (0 - cam.K.cx) / cam.K.fx - 0.2);
}

TEST(SensorRig, IdealRigMatchesTheConfigAndNamesAreChecked) {
  SimConfig c = PresetConfig("tiny");
  const SensorRig ideal = MakeSensorRig(c);
  EXPECT_TRUE(ideal.cam[0].distortion.IsZero());
  EXPECT_TRUE(ideal.T_vehicle_body.isApprox(SE3::Identity()));
  const SE3 T01 = ideal.cam[0].T_body_cam.inverse() * ideal.cam[1].T_body_cam;
  EXPECT_NEAR(T01.translation().x(), c.baseline, 1e-12);
  c.rig = "fisheye";
  EXPECT_THROW(MakeSensorRig(c), Error);
  EXPECT_THROW(Validate(c), Error);
  NoiseLevel level;
  ASSERT_TRUE(ParseNoiseLevel("euroc", &level));
  EXPECT_DOUBLE_EQ(NoiseFor(level).gyro_random_walk, 1.9393e-5);
  Validate(PresetConfig("euroc"));
}

TEST(SensorRig, EurocPresetSequenceReadsBackAsEuroc) {
  SimConfig c = PresetConfig("euroc");
  c.duration_s = 0.1;  // 3 stereo pairs: the checks are on calibration and frames
  c.length_m = 0.3;
  c.threads = 2;
  const fs::path dir = mapdelta::testing::FreshTempDir("mapdelta_test_sim_euroc_rig");
  fs::remove_all(dir);
  GenerateSequence(c, BuildScenes(c), "S1_01", dir.string(), nullptr);
  const EurocSequence seq = ReadEurocSequence((dir / "sequences/S1_01").string());
  const SensorRig rig = EurocMh01Rig();
  EXPECT_EQ(seq.cam0.intrinsics.width, 752);
  EXPECT_DOUBLE_EQ(seq.cam1.intrinsics.fy, 456.134);
  ASSERT_EQ(seq.cam1.distortion.size(), 4u);
  EXPECT_DOUBLE_EQ(seq.cam1.distortion[3], -3.55590700e-05);
  EXPECT_EQ(seq.cam0.distortion_model, "radial-tangential");
  for (int i = 0; i < 2; ++i) {
    const EurocCamera& e = i == 0 ? seq.cam0 : seq.cam1;
    EXPECT_LT((e.T_body_cam.matrix() - rig.cam[i].T_body_cam.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  }
  EXPECT_DOUBLE_EQ(seq.imu.rate_hz, 200.0);
  EXPECT_DOUBLE_EQ(seq.imu.noise.accelerometer_noise_density, 2.0e-3);
  ASSERT_EQ(seq.cam0_images.size(), 3u);
  ASSERT_FALSE(seq.groundtruth.empty());
  // The ground truth is T_map_imu: the IMU reads the specific force R^T (a + g z); the
  // trajectory is nearly unaccelerated here, and EuRoC's IMU x axis points up.
  const SE3& T0 = seq.groundtruth.front().T;
  const Eigen::Vector3d g_imu = T0.linear().transpose() * Eigen::Vector3d(0, 0, 9.81);
  EXPECT_LT((seq.imu_samples.front().accel - g_imu).norm(), 0.3);
  EXPECT_GT(g_imu.x(), 9.7);
  // cam0 looks forward along the flight, level within EuRoC's ~1.5 degree mounting tilt.
  const Eigen::Vector3d axis = (T0 * seq.cam0.T_body_cam).linear().col(2);
  const Eigen::Vector3d p0 = seq.groundtruth.front().T.translation();
  const Eigen::Vector3d p1 = seq.groundtruth.back().T.translation();
  EXPECT_LT(std::abs(axis.z()), std::sin(2.0 * M_PI / 180));
  EXPECT_GT(axis.dot((p1 - p0).normalized()), std::cos(5.0 * M_PI / 180));
}

}  // namespace
}  // namespace mapdelta::sim

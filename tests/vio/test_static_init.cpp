// Initialization at rest (Initializer + rest_detector), on synthetic data with known truth: a
// stereo rig standing tilted (roll 3 deg, pitch -2 deg) with a gyro bias, exact stereo features
// of random landmarks, IMU at 200 Hz with white noise at EuRoC's densities. At rest it must
// initialize as soon as the frames span StaticInitConfig::window_s, with the true tilt, the
// true gyro bias and zero velocity. It must not when the IMU reads rest but the cameras move (a
// vehicle at constant speed), nor when the IMU vibrates.
#include <gtest/gtest.h>

#include "mapdelta/vio/initializer.hpp"
#include "mapdelta/vio/rest_detector.hpp"
#include "synthetic_init_scene.hpp"

using namespace mapdelta;
using namespace mapdelta::vio;
using namespace mapdelta::vio::testing;

TEST(StaticInit, AtRestInitializesAfterTheRestWindowWithTiltAndGyroBias) {
  Scene scene;
  const Outcome out = RunUntilInitialized(&scene, 1.0);
  ASSERT_TRUE(out.frames.has_value());
  EXPECT_NEAR(out.at_s, VioConfig{}.static_init.window_s, 1e-9);  // the first frame that spans it
  ASSERT_GE(out.frames->size(), 5u);
  for (const InitFrame& f : *out.frames) {
    // Mean of 51 accelerometer samples, sigma 0.028 m/s^2 each: 0.023 deg per tilt axis.
    EXPECT_LT(TiltDeg(f.state.T_world_body.linear(), scene.R_world_body), 0.1);
    EXPECT_LT((f.state.bg - kGyroBias).norm(), 1.5e-3);  // mean of 50 samples, sigma 2.4e-3 each
    EXPECT_EQ(f.state.v_world.norm(), 0.0);
  }
}

TEST(StaticInit, ImuAtRestButCamerasMovingIsNotRest) {
  Scene scene;
  scene.speed = 1.0;  // constant speed: the IMU reads exactly what it reads at rest
  const Outcome out = RunUntilInitialized(&scene, 0.8);
  EXPECT_FALSE(out.frames.has_value()) << "initialized at " << out.at_s << " s";
}

TEST(StaticInit, VibratingImuIsNotRest) {
  Scene scene;
  scene.accel_vibration = 0.8;  // EuRoC V1_01 with the rotors running: 0.8 m/s^2 spread
  const Outcome out = RunUntilInitialized(&scene, 0.8);
  EXPECT_FALSE(out.frames.has_value()) << "initialized at " << out.at_s << " s";
}

TEST(RestDetector, SaysWhyNot) {
  StaticInitConfig config;
  std::vector<ImuSample> samples;
  for (int i = 0; i <= 50; ++i) {
    ImuSample s;
    s.t_ns = i * 5'000'000;
    s.accel = Eigen::Vector3d(0, 0, 9.81 + (i % 2 ? 0.5 : -0.5));
    samples.push_back(s);
  }
  const RestCheck shaking = CheckImuRest(samples, config, 9.81);
  EXPECT_FALSE(shaking.at_rest);
  EXPECT_NEAR(shaking.stats.accel_std, 0.5, 0.01);
  EXPECT_NE(shaking.reason.find("accelerometer spread"), std::string::npos) << shaking.reason;
  for (auto& s : samples) s.accel.z() = 9.81;
  EXPECT_TRUE(CheckImuRest(samples, config, 9.81).at_rest);
  samples.resize(20);  // 0.095 s of a 0.25 s window
  const RestCheck short_window = CheckImuRest(samples, config, 9.81);
  EXPECT_FALSE(short_window.at_rest);
  EXPECT_NE(short_window.reason.find("IMU samples over"), std::string::npos) << short_window.reason;
}

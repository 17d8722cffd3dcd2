// Initialization at rest (Initializer + rest_detector), on synthetic data with known truth: a
// stereo rig standing tilted (roll 3 deg, pitch -2 deg) with a gyro bias, exact stereo features
// of random landmarks, IMU at 200 Hz with white noise at EuRoC's densities. At rest it must
// initialize as soon as the frames span StaticInitConfig::window_s, with the true tilt, the
// true gyro bias and zero velocity. It must not when the IMU reads rest but the cameras move (a
// vehicle at constant speed), nor when the IMU vibrates.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "mapdelta/vio/initializer.hpp"
#include "mapdelta/vio/rest_detector.hpp"

using namespace mapdelta;
using namespace mapdelta::vio;

namespace {

constexpr double kFrameDt = 0.05;                       // 20 Hz
constexpr int kImuPerFrame = 10;                        // 200 Hz
const Eigen::Vector3d kGyroBias(-0.002, 0.021, 0.078);  // EuRoC V1_01's, rad/s

StereoExtrinsics Rig() {
  // Camera z forward (body x), x right (body -y), y down (body -z); cam1 0.11 m to the right.
  Eigen::Matrix3d R_body_cam;
  R_body_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  StereoExtrinsics ext;
  ext.T_body_cam0.linear() = R_body_cam;
  ext.T_body_cam0.translation() = Eigen::Vector3d(0.1, 0.055, 0);
  ext.T_body_cam1 = ext.T_body_cam0;
  ext.T_body_cam1.translation() = Eigen::Vector3d(0.1, -0.055, 0);
  ext.focal_px = 450.0;
  return ext;
}

ImuNoiseDensities Noise() {
  ImuNoiseDensities n;
  n.gyroscope_noise_density = 1.7e-4;
  n.accelerometer_noise_density = 2e-3;
  n.gyroscope_random_walk = 2e-5;
  n.accelerometer_random_walk = 3e-3;
  return n;
}

struct Scene {
  Eigen::Matrix3d R_world_body;  // constant
  double speed = 0;              // m/s along body x
  double accel_vibration = 0;    // extra white accelerometer noise, m/s^2
  std::mt19937 rng{3};
  std::vector<Eigen::Vector3d> landmarks;

  Scene() {
    R_world_body = (Eigen::AngleAxisd(-2.0 * M_PI / 180, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(3.0 * M_PI / 180, Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
    std::uniform_real_distribution<double> ahead(2, 12), side(-5, 5), height(-2, 3);
    for (int i = 0; i < 300; ++i) landmarks.emplace_back(ahead(rng), side(rng), height(rng));
  }
  SE3 Pose(double t) const {
    SE3 T = SE3::Identity();
    T.linear() = R_world_body;
    T.translation() = R_world_body * Eigen::Vector3d(speed * t, 0, 0);
    return T;
  }
  ImuSample Sample(double t) {
    const double gyro_sigma = 1.7e-4 * std::sqrt(200.0), accel_sigma = 2e-3 * std::sqrt(200.0);
    std::normal_distribution<double> g(0, gyro_sigma),
        a(0, std::hypot(accel_sigma, accel_vibration));
    ImuSample s;
    s.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    s.gyro = kGyroBias + Eigen::Vector3d(g(rng), g(rng), g(rng));
    s.accel = R_world_body.transpose() * Eigen::Vector3d(0, 0, 9.81) +
              Eigen::Vector3d(a(rng), a(rng), a(rng));
    return s;
  }
  FrameFeatures Features(double t, const StereoExtrinsics& ext) const {
    FrameFeatures f;
    f.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    const SE3 T_c0_w = (Pose(t) * ext.T_body_cam0).inverse(),
              T_c1_w = (Pose(t) * ext.T_body_cam1).inverse();
    for (size_t id = 0; id < landmarks.size(); ++id) {
      const Eigen::Vector3d p0 = T_c0_w * landmarks[id], p1 = T_c1_w * landmarks[id];
      if (p0.z() < 1 || p1.z() < 1) continue;
      const Eigen::Vector2d l = p0.head<2>() / p0.z(), r = p1.head<2>() / p1.z();
      if (std::abs(l.x()) > 0.8 || std::abs(l.y()) > 0.5) continue;
      f.features.push_back({id + 1, l, true, r});
    }
    return f;
  }
};

struct Outcome {
  std::optional<std::vector<InitFrame>> frames;
  double at_s = -1;
};

// Frames until the initializer returns, or for `max_s`.
Outcome RunUntilInitialized(Scene* scene, double max_s) {
  const StereoExtrinsics ext = Rig();
  VioConfig config;
  Initializer initializer(config, ext);
  for (int k = 0; k * kFrameDt <= max_s + 1e-9; ++k) {
    const double t = k * kFrameDt;
    ImuPreintegration pre(Noise(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    if (k > 0) {
      for (int i = 0; i <= kImuPerFrame; ++i)
        pre.Add(scene->Sample(t - kFrameDt + i * kFrameDt / kImuPerFrame));
    }
    auto frames = initializer.AddFrame(scene->Features(t, ext), pre);
    if (frames) return {std::move(frames), t};
  }
  return {};
}

double TiltDeg(const Eigen::Matrix3d& R_world_body_estimate,
               const Eigen::Matrix3d& R_world_body_truth) {
  const Eigen::Vector3d up_est = R_world_body_estimate.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_true = R_world_body_truth.transpose() * Eigen::Vector3d::UnitZ();
  return std::acos(std::clamp(up_est.dot(up_true), -1.0, 1.0)) * 180 / M_PI;
}

}  // namespace

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

#pragma once
// Synthetic data for the initializer's tests, with known truth: a stereo rig (EuRoC-like, 0.11 m
// baseline) at a constant attitude (roll 3 deg, pitch -2 deg) moving along its x axis at a
// given speed and acceleration, exact stereo features of random landmarks ahead, and a 200 Hz
// IMU with a gyro bias and white noise at EuRoC's densities.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include "mapdelta/vio/initializer.hpp"

namespace mapdelta::vio::testing {

inline constexpr double kFrameDt = 0.05;                       // 20 Hz
inline constexpr int kImuPerFrame = 10;                        // 200 Hz
inline const Eigen::Vector3d kGyroBias(-0.002, 0.021, 0.078);  // EuRoC V1_01's, rad/s

// Camera z forward (body x), x right (body -y), y down (body -z); cam0 at `cam0_in_body`, cam1
// `baseline_m` to its right.
inline StereoExtrinsics Rig(double baseline_m = 0.11,
                            const Eigen::Vector3d& cam0_in_body = Eigen::Vector3d(0.1, 0.055, 0),
                            double focal_px = 450.0) {
  Eigen::Matrix3d R_body_cam;
  R_body_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  StereoExtrinsics ext;
  ext.T_body_cam0.linear() = R_body_cam;
  ext.T_body_cam0.translation() = cam0_in_body;
  ext.T_body_cam1 = ext.T_body_cam0;
  ext.T_body_cam1.translation() = cam0_in_body - Eigen::Vector3d(0, baseline_m, 0);
  ext.focal_px = focal_px;
  return ext;
}

inline ImuNoiseDensities Noise() {
  ImuNoiseDensities n;
  n.gyroscope_noise_density = 1.7e-4;
  n.accelerometer_noise_density = 2e-3;
  n.gyroscope_random_walk = 2e-5;
  n.accelerometer_random_walk = 3e-3;
  return n;
}

struct Scene {
  Eigen::Matrix3d R_world_body;  // constant
  double speed = 0;              // m/s along body x at t = 0
  double accel = 0;              // m/s^2 along body x
  double accel_vibration = 0;    // extra white accelerometer noise, m/s^2
  // A visual error: the cameras see the rig rise as if accelerating up at this rate (m/s^2)
  // while the IMU does not feel it, so the stereo chain and the IMU disagree about gravity.
  double camera_only_lift = 0;
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
    T.translation() = R_world_body * Eigen::Vector3d(speed * t + 0.5 * accel * t * t, 0, 0);
    return T;
  }
  Eigen::Vector3d Velocity(double t) const {
    return R_world_body * Eigen::Vector3d(speed + accel * t, 0, 0);
  }
  ImuSample Sample(double t) {
    const double gyro_sigma = 1.7e-4 * std::sqrt(200.0), accel_sigma = 2e-3 * std::sqrt(200.0);
    std::normal_distribution<double> g(0, gyro_sigma),
        a(0, std::hypot(accel_sigma, accel_vibration));
    ImuSample s;
    s.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    s.gyro = kGyroBias + Eigen::Vector3d(g(rng), g(rng), g(rng));
    s.accel = R_world_body.transpose() * Eigen::Vector3d(0, 0, 9.81) +
              Eigen::Vector3d(accel, 0, 0) + Eigen::Vector3d(a(rng), a(rng), a(rng));
    return s;
  }
  // Exact projections through the true rig (`ext`).
  FrameFeatures Features(double t, const StereoExtrinsics& ext) const {
    FrameFeatures f;
    f.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    SE3 T_world_body = Pose(t);
    T_world_body.translation().z() += 0.5 * camera_only_lift * t * t;
    const SE3 T_c0_w = (T_world_body * ext.T_body_cam0).inverse(),
              T_c1_w = (T_world_body * ext.T_body_cam1).inverse();
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

// Frames until the initializer returns, or for `max_s`. The initializer believes `believed_rig`
// (default: the true one); the features come from the true rig.
inline Outcome RunUntilInitialized(Scene* scene, double max_s, const VioConfig& config = {},
                                   const StereoExtrinsics& believed_rig = Rig()) {
  Initializer initializer(config, believed_rig);
  for (int k = 0; k * kFrameDt <= max_s + 1e-9; ++k) {
    const double t = k * kFrameDt;
    ImuPreintegration pre(Noise(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    if (k > 0) {
      for (int i = 0; i <= kImuPerFrame; ++i)
        pre.Add(scene->Sample(t - kFrameDt + i * kFrameDt / kImuPerFrame));
    }
    auto frames = initializer.AddFrame(scene->Features(t, Rig()), pre);
    if (frames) return {std::move(frames), t};
  }
  return {};
}

// Angle between the estimated and the true up direction in the body frame, degrees.
inline double TiltDeg(const Eigen::Matrix3d& R_world_body_estimate,
                      const Eigen::Matrix3d& R_world_body_truth) {
  const Eigen::Vector3d up_est = R_world_body_estimate.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_true = R_world_body_truth.transpose() * Eigen::Vector3d::UnitZ();
  return std::acos(std::clamp(up_est.dot(up_true), -1.0, 1.0)) * 180 / M_PI;
}

}  // namespace mapdelta::vio::testing

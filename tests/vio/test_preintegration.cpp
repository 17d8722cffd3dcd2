// Preintegration against an analytic motion, and its bias Jacobians against finite
// differences of full re-integration.
#include <gtest/gtest.h>

#include <cmath>

#include "mapdelta/vio/imu_preintegration.hpp"

using namespace mapdelta;
using namespace mapdelta::vio;

namespace {

const Eigen::Vector3d kGravity(0, 0, -9.81);

// Body rotates at a constant body rate w from R0; position follows an analytic curve.
struct Motion {
  Eigen::Vector3d w{0.3, -0.2, 0.5};
  Eigen::Quaterniond R0 = ExpQuaternion(Eigen::Vector3d(0.1, 0.2, -0.3));
  Eigen::Matrix3d R(double t) const { return (R0 * ExpQuaternion(w * t)).toRotationMatrix(); }
  Eigen::Vector3d p(double t) const {
    return {3 * std::sin(t), 2 * std::cos(0.5 * t), 0.4 * t * t};
  }
  Eigen::Vector3d v(double t) const { return {3 * std::cos(t), -std::sin(0.5 * t), 0.8 * t}; }
  Eigen::Vector3d a(double t) const { return {-3 * std::sin(t), -0.5 * std::cos(0.5 * t), 0.8}; }
  ImuSample Sample(double t, const Eigen::Vector3d& bg = Eigen::Vector3d::Zero(),
                   const Eigen::Vector3d& ba = Eigen::Vector3d::Zero()) const {
    ImuSample s;
    s.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    s.gyro = w + bg;
    s.accel = R(t).transpose() * (a(t) - kGravity) + ba;  // specific force
    return s;
  }
};

ImuNoiseDensities SomeNoise() {
  ImuNoiseDensities n;
  n.gyroscope_noise_density = 4e-4;
  n.accelerometer_noise_density = 3e-3;
  n.gyroscope_random_walk = 4e-5;
  n.accelerometer_random_walk = 3e-4;
  return n;
}

}  // namespace

TEST(Preintegration, MatchesAnalyticMotion) {
  const Motion m;
  ImuPreintegration pre(SomeNoise(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  const double T = 1.0;
  for (int k = 0; k <= 1000; ++k) pre.Add(m.Sample(k * T / 1000));
  EXPECT_NEAR(pre.dt(), T, 1e-12);
  const Eigen::Matrix3d R0 = m.R(0);
  const Eigen::Vector3d dp_true =
      R0.transpose() * (m.p(T) - m.p(0) - m.v(0) * T - 0.5 * kGravity * T * T);
  const Eigen::Vector3d dv_true = R0.transpose() * (m.v(T) - m.v(0) - kGravity * T);
  const Eigen::Matrix3d dR_true = R0.transpose() * m.R(T);
  EXPECT_LT((pre.dR().toRotationMatrix() - dR_true).norm(), 1e-9);
  EXPECT_LT((pre.dv() - dv_true).norm(), 2e-4)
      << pre.dv().transpose() << " vs " << dv_true.transpose();
  EXPECT_LT((pre.dp() - dp_true).norm(), 2e-4)
      << pre.dp().transpose() << " vs " << dp_true.transpose();
  // Predict() reproduces the end state.
  Eigen::Quaterniond Rj;
  Eigen::Vector3d pj, vj;
  pre.Predict(kGravity, Eigen::Quaterniond(R0), m.p(0), m.v(0), &Rj, &pj, &vj);
  EXPECT_LT((pj - m.p(T)).norm(), 5e-4);
  EXPECT_LT((vj - m.v(T)).norm(), 5e-4);
  // Covariance: symmetric, positive, growing with time.
  EXPECT_LT((pre.covariance() - pre.covariance().transpose()).norm(), 1e-15);
  EXPECT_GT(pre.covariance()(6, 6), 0);
  // A sequence biased by (bg, ba) and integrated at that bias gives the same deltas.
  const Eigen::Vector3d bg(0.01, -0.02, 0.015), ba(0.1, -0.05, 0.2);
  ImuPreintegration biased(SomeNoise(), bg, ba);
  for (int k = 0; k <= 1000; ++k) biased.Add(m.Sample(k * T / 1000, bg, ba));
  EXPECT_LT((biased.dp() - pre.dp()).norm(), 1e-9);
  EXPECT_LT((biased.dv() - pre.dv()).norm(), 1e-9);
}

TEST(Preintegration, DiscreteNoiseFromDensities) {
  const DiscreteImuNoise n = DiscreteImuNoise::FromDensities(SomeNoise(), 0.005);
  EXPECT_NEAR(n.gyro_var, 4e-4 * 4e-4 / 0.005, 1e-18);
  EXPECT_NEAR(n.accel_bias_var, 3e-4 * 3e-4 * 0.005, 1e-18);
  // Without gyro noise, velocity variance after T seconds is sigma_a^2 * T per axis.
  const Motion m;
  ImuNoiseDensities accel_only = SomeNoise();
  accel_only.gyroscope_noise_density = 0;
  accel_only.gyroscope_random_walk = 0;
  accel_only.accelerometer_random_walk = 0;
  ImuPreintegration pre(accel_only, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  for (int k = 0; k <= 400; ++k) pre.Add(m.Sample(k * 0.005));
  EXPECT_NEAR(pre.covariance()(3, 3) + pre.covariance()(4, 4) + pre.covariance()(5, 5),
              3 * 3e-3 * 3e-3 * 2.0, 1e-3 * 3 * 3e-3 * 3e-3 * 2.0);
}

TEST(Preintegration, BiasJacobiansMatchFiniteDifferences) {
  const Motion m;
  ImuPreintegration base(SomeNoise(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  for (int k = 0; k <= 300; ++k) base.Add(m.Sample(k * 0.002));
  const double h = 1e-6;
  for (int bias = 0; bias < 2; ++bias) {
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3d bg = Eigen::Vector3d::Zero(), ba = Eigen::Vector3d::Zero();
      (bias == 0 ? bg : ba)[axis] = h;
      ImuPreintegration moved = base;
      moved.Reintegrate(bg, ba);
      const Eigen::Vector3d dtheta =
          LogQuaternion((base.dR().conjugate() * moved.dR()).normalized()) / h;
      const Eigen::Vector3d dv = (moved.dv() - base.dv()) / h;
      const Eigen::Vector3d dp = (moved.dp() - base.dp()) / h;
      const int col = (bias == 0 ? 9 : 12) + axis;
      EXPECT_LT((dtheta - base.jacobian().block<3, 1>(0, col)).norm(), 1e-5) << col;
      EXPECT_LT((dv - base.jacobian().block<3, 1>(3, col)).norm(), 1e-5) << col;
      EXPECT_LT((dp - base.jacobian().block<3, 1>(6, col)).norm(), 1e-5) << col;
      // First-order correction agrees with re-integration for a moderate bias change.
      const Eigen::Vector3d bg2 = bg * 1e3, ba2 = ba * 1e3;  // 1e-3
      ImuPreintegration far = base;
      far.Reintegrate(bg2, ba2);
      EXPECT_LT((base.CorrectedDp(bg2, ba2) - far.dp()).norm(), 1e-6);
      EXPECT_LT((base.CorrectedDv(bg2, ba2) - far.dv()).norm(), 1e-6);
      EXPECT_LT(LogQuaternion((base.CorrectedDR(bg2).conjugate() * far.dR()).normalized()).norm(),
                1e-6);
    }
  }
}

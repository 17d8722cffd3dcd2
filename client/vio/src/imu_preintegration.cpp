#include "mapdelta/vio/imu_preintegration.hpp"

#include <cmath>

namespace mapdelta::vio {

DiscreteImuNoise DiscreteImuNoise::FromDensities(const ImuNoiseDensities& d, double dt_s) {
  DiscreteImuNoise n;
  // White noise: a density sigma_c [unit/sqrt(Hz)] sampled at 1/dt has variance sigma_c^2/dt.
  n.gyro_var = d.gyroscope_noise_density * d.gyroscope_noise_density / dt_s;
  n.accel_var = d.accelerometer_noise_density * d.accelerometer_noise_density / dt_s;
  // Random walk: the bias diffuses by variance sigma_c^2 * dt over a step of dt.
  n.gyro_bias_var = d.gyroscope_random_walk * d.gyroscope_random_walk * dt_s;
  n.accel_bias_var = d.accelerometer_random_walk * d.accelerometer_random_walk * dt_s;
  return n;
}

ImuPreintegration::ImuPreintegration(const ImuNoiseDensities& noise, const Eigen::Vector3d& bg,
                                     const Eigen::Vector3d& ba)
    : noise_(noise), bg0_(bg), ba0_(ba) {}

void ImuPreintegration::Reset() {
  dt_s_ = 0;
  dR_.setIdentity();
  dv_.setZero();
  dp_.setZero();
  cov_.setZero();
  jac_.setIdentity();
}

void ImuPreintegration::Add(const ImuSample& sample) {
  if (!samples_.empty()) {
    if (sample.t_ns <= samples_.back().t_ns) return;  // duplicates/out-of-order carry no time
    Step(samples_.back(), sample);
  }
  samples_.push_back(sample);
}

void ImuPreintegration::Step(const ImuSample& a, const ImuSample& b) {
  const double dt = 1e-9 * static_cast<double>(b.t_ns - a.t_ns);
  const Eigen::Vector3d w = 0.5 * (a.gyro + b.gyro) - bg0_;
  const Eigen::Vector3d acc = 0.5 * (a.accel + b.accel) - ba0_;
  const Eigen::Matrix3d R = dR_.toRotationMatrix();
  const Eigen::Vector3d phi = w * dt;
  const Eigen::Matrix3d Jr = RightJacobianSO3(phi);
  // The averaged acceleration is rotated by the mid-step rotation R * Exp(phi / 2): a
  // start-of-step rotation leaves a first-order error of |w| dt |a| per step.
  const Eigen::Matrix3d E_half = ExpQuaternion(0.5 * phi).toRotationMatrix();
  const Eigen::Matrix3d R_half = R * E_half;
  const Eigen::Matrix3d RA = R_half * Skew(acc);
  const Eigen::Matrix3d RA_theta = RA * E_half.transpose();                   // d/d(dtheta)
  const Eigen::Matrix3d RA_bg = 0.5 * dt * RA * RightJacobianSO3(0.5 * phi);  // d/d(bg)

  // 1. Linearized error-state transition F and noise input G (see header for the order).
  Matrix15d F = Matrix15d::Identity();
  F.block<3, 3>(0, 0) = ExpQuaternion(phi).toRotationMatrix().transpose();
  F.block<3, 3>(0, 9) = -Jr * dt;
  F.block<3, 3>(3, 0) = -RA_theta * dt;
  F.block<3, 3>(3, 9) = RA_bg * dt;
  F.block<3, 3>(3, 12) = -R_half * dt;
  F.block<3, 3>(6, 0) = -0.5 * RA_theta * dt * dt;
  F.block<3, 3>(6, 3) = Eigen::Matrix3d::Identity() * dt;
  F.block<3, 3>(6, 9) = 0.5 * RA_bg * dt * dt;
  F.block<3, 3>(6, 12) = -0.5 * R_half * dt * dt;
  Eigen::Matrix<double, 15, 12> G = Eigen::Matrix<double, 15, 12>::Zero();
  G.block<3, 3>(0, 0) = Jr * dt;
  G.block<3, 3>(3, 3) = R_half * dt;
  G.block<3, 3>(6, 3) = 0.5 * R_half * dt * dt;
  G.block<3, 3>(9, 6).setIdentity();
  G.block<3, 3>(12, 9).setIdentity();
  const DiscreteImuNoise n = DiscreteImuNoise::FromDensities(noise_, dt);
  Eigen::Matrix<double, 12, 1> q;
  q << Eigen::Vector3d::Constant(n.gyro_var), Eigen::Vector3d::Constant(n.accel_var),
      Eigen::Vector3d::Constant(n.gyro_bias_var), Eigen::Vector3d::Constant(n.accel_bias_var);

  // 2. Covariance and bias Jacobians (the bias columns of the accumulated transition).
  cov_ = F * cov_ * F.transpose() + G * q.asDiagonal() * G.transpose();
  jac_ = F * jac_;

  // 3. Deltas, position first because it uses the old velocity and rotation.
  dp_ += dv_ * dt + 0.5 * R_half * acc * dt * dt;
  dv_ += R_half * acc * dt;
  dR_ = (dR_ * ExpQuaternion(phi)).normalized();
  dt_s_ += dt;
}

void ImuPreintegration::Reintegrate(const Eigen::Vector3d& bg, const Eigen::Vector3d& ba) {
  bg0_ = bg;
  ba0_ = ba;
  Reset();
  for (size_t k = 1; k < samples_.size(); ++k) Step(samples_[k - 1], samples_[k]);
}

void ImuPreintegration::Append(const ImuPreintegration& next) {
  for (const auto& s : next.samples_) Add(s);
}

Eigen::Quaterniond ImuPreintegration::CorrectedDR(const Eigen::Vector3d& bg) const {
  return (dR_ * ExpQuaternion(J_R_bg() * (bg - bg0_))).normalized();
}

Eigen::Vector3d ImuPreintegration::CorrectedDv(const Eigen::Vector3d& bg,
                                               const Eigen::Vector3d& ba) const {
  return dv_ + J_v_bg() * (bg - bg0_) + J_v_ba() * (ba - ba0_);
}

Eigen::Vector3d ImuPreintegration::CorrectedDp(const Eigen::Vector3d& bg,
                                               const Eigen::Vector3d& ba) const {
  return dp_ + J_p_bg() * (bg - bg0_) + J_p_ba() * (ba - ba0_);
}

bool ImuPreintegration::BiasMovedFar(const Eigen::Vector3d& bg, const Eigen::Vector3d& ba,
                                     double gyro_limit, double accel_limit) const {
  return (bg - bg0_).norm() > gyro_limit || (ba - ba0_).norm() > accel_limit;
}

void ImuPreintegration::Predict(const Eigen::Vector3d& g, const Eigen::Quaterniond& R_i,
                                const Eigen::Vector3d& p_i, const Eigen::Vector3d& v_i,
                                Eigen::Quaterniond* R_j, Eigen::Vector3d* p_j,
                                Eigen::Vector3d* v_j) const {
  *R_j = (R_i * dR_).normalized();
  *v_j = v_i + g * dt_s_ + R_i * dv_;
  *p_j = p_i + v_i * dt_s_ + 0.5 * g * dt_s_ * dt_s_ + R_i * dp_;
}

}  // namespace mapdelta::vio

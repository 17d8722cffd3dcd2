#pragma once
// IMU preintegration between two frames (Forster et al. 2017 on the right-perturbed SO(3)),
// with bias Jacobians, a 15x15 covariance propagated from discrete noise, first-order bias
// correction and full re-integration when the bias moves far from its linearization point.
//
// Error-state order (also the IMU factor's residual order):
//   [0] dtheta (3), [3] dv (3), [6] dp (3), [9] bg (3), [12] ba (3).
// Measurements between samples are averaged (mid-point in measurement), so a step uses
// 0.5 * (m_k + m_{k+1}) over dt = t_{k+1} - t_k.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/lie.hpp"  // Skew, RightJacobianSO3, ExpQuaternion, LogQuaternion

namespace mapdelta::vio {

using Matrix15d = Eigen::Matrix<double, 15, 15>;
using Vector15d = Eigen::Matrix<double, 15, 1>;

// Continuous densities converted explicitly to what one sample period of dt needs:
// white noise sigma_d = sigma_c / sqrt(dt); bias random walk variance per step sigma_c^2 * dt.
struct DiscreteImuNoise {
  double gyro_var = 0, accel_var = 0;            // per-sample measurement variance
  double gyro_bias_var = 0, accel_bias_var = 0;  // bias variance added per step
  static DiscreteImuNoise FromDensities(const ImuNoiseDensities& d, double dt_s);
};

class ImuPreintegration {
 public:
  ImuPreintegration() = default;
  ImuPreintegration(const ImuNoiseDensities& noise, const Eigen::Vector3d& bg,
                    const Eigen::Vector3d& ba);

  // Appends a measurement; the first call only sets the start sample.
  void Add(const ImuSample& sample);
  // Re-integrates all stored samples at a new linearization bias.
  void Reintegrate(const Eigen::Vector3d& bg, const Eigen::Vector3d& ba);
  // Appends another preintegration's samples (used when a frame between them is dropped).
  void Append(const ImuPreintegration& next);

  double dt() const { return dt_s_; }
  int64_t t_start_ns() const { return samples_.empty() ? 0 : samples_.front().t_ns; }
  int64_t t_end_ns() const { return samples_.empty() ? 0 : samples_.back().t_ns; }
  const Eigen::Quaterniond& dR() const { return dR_; }
  const Eigen::Vector3d& dv() const { return dv_; }
  const Eigen::Vector3d& dp() const { return dp_; }
  const Eigen::Vector3d& bg0() const { return bg0_; }
  const Eigen::Vector3d& ba0() const { return ba0_; }
  const Matrix15d& covariance() const { return cov_; }
  // d(error state)/d(bias) in the [dtheta, dv, dp] x [bg, ba] blocks of this 15x15 matrix.
  const Matrix15d& jacobian() const { return jac_; }
  Eigen::Matrix3d J_R_bg() const { return jac_.block<3, 3>(0, 9); }
  Eigen::Matrix3d J_v_bg() const { return jac_.block<3, 3>(3, 9); }
  Eigen::Matrix3d J_v_ba() const { return jac_.block<3, 3>(3, 12); }
  Eigen::Matrix3d J_p_bg() const { return jac_.block<3, 3>(6, 9); }
  Eigen::Matrix3d J_p_ba() const { return jac_.block<3, 3>(6, 12); }
  const std::vector<ImuSample>& samples() const { return samples_; }
  const ImuNoiseDensities& noise() const { return noise_; }

  // First-order corrected deltas at bias (bg, ba).
  Eigen::Quaterniond CorrectedDR(const Eigen::Vector3d& bg) const;
  Eigen::Vector3d CorrectedDv(const Eigen::Vector3d& bg, const Eigen::Vector3d& ba) const;
  Eigen::Vector3d CorrectedDp(const Eigen::Vector3d& bg, const Eigen::Vector3d& ba) const;
  // True when the first-order correction is no longer trustworthy.
  bool BiasMovedFar(const Eigen::Vector3d& bg, const Eigen::Vector3d& ba, double gyro_limit = 0.01,
                    double accel_limit = 0.2) const;

  // Propagates a state (R, p, v in world) over this interval with gravity g_world.
  void Predict(const Eigen::Vector3d& g_world, const Eigen::Quaterniond& R_i,
               const Eigen::Vector3d& p_i, const Eigen::Vector3d& v_i, Eigen::Quaterniond* R_j,
               Eigen::Vector3d* p_j, Eigen::Vector3d* v_j) const;

 private:
  void Reset();
  void Step(const ImuSample& a, const ImuSample& b);

  ImuNoiseDensities noise_;
  Eigen::Vector3d bg0_ = Eigen::Vector3d::Zero(), ba0_ = Eigen::Vector3d::Zero();
  std::vector<ImuSample> samples_;
  double dt_s_ = 0;
  Eigen::Quaterniond dR_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d dv_ = Eigen::Vector3d::Zero(), dp_ = Eigen::Vector3d::Zero();
  Matrix15d cov_ = Matrix15d::Zero();
  Matrix15d jac_ = Matrix15d::Identity();
};

}  // namespace mapdelta::vio

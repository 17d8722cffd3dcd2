#pragma once
// Ceres parameterization and residuals of the sliding window. Internal to mapdelta_vio and
// its tests (this header pulls in Ceres; do not include it from widely used headers).
//
// Parameter blocks:
//   pose [7]        = p_world_body (3), q_world_body (x, y, z, w: Eigen order)
//   speed_bias [9]  = v_world (3), bg (3), ba (3)
//   inverse depth[1]= 1 / z of a landmark in its anchor frame's cam0
// Pose tangent: [dp (3), dtheta (3)] with p + dp, q * Exp(dtheta) (right perturbation).
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mapdelta/common/pose.hpp"
#include "mapdelta/vio/imu_preintegration.hpp"

namespace mapdelta::vio {

class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;  // 7x6 row-major
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;  // 6x7 row-major
};

// Tangent size of a block by its ambient size (7 = pose, otherwise Euclidean).
inline int TangentSizeOf(int ambient) { return ambient == 7 ? 6 : ambient; }
// Ambient->tangent Jacobian conversion: J_tangent = J_ambient * PlusJacobian(x).
Eigen::MatrixXd ToTangentJacobian(const double* x, int ambient,
                                  const Eigen::Ref<const Eigen::MatrixXd>& J_ambient);
// y - x in the tangent space at x.
Eigen::VectorXd TangentMinus(const double* y, const double* x, int ambient);

void PoseToArray(const SE3& T_world_body, double* pose);
SE3 ArrayToPose(const double* pose);

// Preintegrated IMU between frames i and j; residual (15) = sqrt_info * [rtheta, rv, rp, rbg, rba].
class ImuFactor {
 public:
  ImuFactor(const ImuPreintegration& pre, const Eigen::Vector3d& g_world);
  static ceres::CostFunction* Create(const ImuPreintegration& pre, const Eigen::Vector3d& g);

  template <typename T>
  bool operator()(const T* pose_i, const T* sb_i, const T* pose_j, const T* sb_j, T* out) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    using Q = Eigen::Quaternion<T>;
    const Eigen::Map<const V3> p_i(pose_i), p_j(pose_j), v_i(sb_i), v_j(sb_j);
    const Eigen::Map<const Q> q_i(pose_i + 3), q_j(pose_j + 3);
    const Eigen::Map<const V3> bg_i(sb_i + 3), ba_i(sb_i + 6), bg_j(sb_j + 3), ba_j(sb_j + 6);
    const V3 dbg = bg_i - bg0_.cast<T>();
    const V3 dba = ba_i - ba0_.cast<T>();
    // First-order bias correction of the preintegrated deltas.
    const V3 phi = J_R_bg_.cast<T>() * dbg;
    T dq_wxyz[4];
    ceres::AngleAxisToQuaternion(phi.data(), dq_wxyz);
    const Q dR_c = dR_.cast<T>() * Q(dq_wxyz[0], dq_wxyz[1], dq_wxyz[2], dq_wxyz[3]);
    const V3 dv_c = dv_.cast<T>() + J_v_bg_.cast<T>() * dbg + J_v_ba_.cast<T>() * dba;
    const V3 dp_c = dp_.cast<T>() + J_p_bg_.cast<T>() * dbg + J_p_ba_.cast<T>() * dba;
    const T dt(dt_);
    const V3 g = g_.cast<T>();
    const Q q_err = dR_c.conjugate() * q_i.conjugate() * q_j;
    const T q_err_wxyz[4] = {q_err.w(), q_err.x(), q_err.y(), q_err.z()};
    Eigen::Matrix<T, 15, 1> r;
    T r_theta[3];
    ceres::QuaternionToAngleAxis(q_err_wxyz, r_theta);
    r.template segment<3>(0) = Eigen::Map<const V3>(r_theta);
    r.template segment<3>(3) = q_i.conjugate() * (v_j - v_i - g * dt) - dv_c;
    r.template segment<3>(6) =
        q_i.conjugate() * (p_j - p_i - v_i * dt - T(0.5) * g * dt * dt) - dp_c;
    r.template segment<3>(9) = bg_j - bg_i;
    r.template segment<3>(12) = ba_j - ba_i;
    Eigen::Map<Eigen::Matrix<T, 15, 1>>{out} = sqrt_info_.cast<T>() * r;
    return true;
  }

 private:
  Eigen::Quaterniond dR_;
  Eigen::Vector3d dv_, dp_, bg0_, ba0_, g_;
  Eigen::Matrix3d J_R_bg_, J_v_bg_, J_v_ba_, J_p_bg_, J_p_ba_;
  double dt_;
  Matrix15d sqrt_info_;
};

// Camera extrinsics shared by the visual factors.
struct CameraExtrinsics {
  Eigen::Quaterniond q_body_cam = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t_body_cam = Eigen::Vector3d::Zero();
};

// A landmark anchored in frame i's cam0 at normalized (x_i, y_i) with inverse depth rho,
// observed at normalized (x_j, y_j) in camera `cam_j` of another frame j. Residual in
// normalized coordinates scaled by `weight` (focal length / pixel sigma).
class ReprojectionFactor {
 public:
  ReprojectionFactor(const Eigen::Vector2d& obs_i, const Eigen::Vector2d& obs_j,
                     const CameraExtrinsics& cam0, const CameraExtrinsics& cam_j, double weight)
      : obs_i_(obs_i), obs_j_(obs_j), cam0_(cam0), cam_j_(cam_j), weight_(weight) {}
  // analytic: closed-form Jacobians (ReprojectionCost, the window's hot factor: autodiff's
  // 15-wide jets took a third of the CPU); false: autodiff of operator() (the reference).
  static ceres::CostFunction* Create(const Eigen::Vector2d& obs_i, const Eigen::Vector2d& obs_j,
                                     const CameraExtrinsics& cam0, const CameraExtrinsics& cam_j,
                                     double weight, bool analytic = true);

  template <typename T>
  bool operator()(const T* pose_i, const T* pose_j, const T* rho, T* out) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    using Q = Eigen::Quaternion<T>;
    const Eigen::Map<const V3> p_i(pose_i), p_j(pose_j);
    const Eigen::Map<const Q> q_i(pose_i + 3), q_j(pose_j + 3);
    // Homogeneous point scaled by rho (projection is scale invariant): stays finite for
    // points at infinity (rho -> 0).
    const V3 f_i(T(obs_i_.x()), T(obs_i_.y()), T(1.0));
    const V3 P_body_i = cam0_.q_body_cam.cast<T>() * f_i + cam0_.t_body_cam.cast<T>() * rho[0];
    const V3 P_world = q_i * P_body_i + p_i * rho[0];
    const V3 P_body_j = q_j.conjugate() * (P_world - p_j * rho[0]);
    const V3 P_cam_j =
        cam_j_.q_body_cam.conjugate().cast<T>() * (P_body_j - cam_j_.t_body_cam.cast<T>() * rho[0]);
    out[0] = T(weight_) * (P_cam_j.x() / P_cam_j.z() - T(obs_j_.x()));
    out[1] = T(weight_) * (P_cam_j.y() / P_cam_j.z() - T(obs_j_.y()));
    return true;
  }

 private:
  Eigen::Vector2d obs_i_, obs_j_;
  CameraExtrinsics cam0_, cam_j_;
  double weight_;
};

// ReprojectionFactor with closed-form Jacobians. Tangent Jacobians (P_c: point in camera j,
// scaled by rho; A = R_body_camj^T, B = A R_j^T):
//   d/dp_i = B rho,  d/dtheta_i = -B R_i [P_body_i]x,  d/dp_j = -B rho,
//   d/dtheta_j = A [P_body_j]x,  d/drho = B (R_i t_body_cam0 + p_i - p_j) - A t_body_camj,
// chained with the projection; quaternion columns = 4 J_theta M^T (M: the manifold's 4x3
// plus Jacobian, whose columns are orthogonal with norm 1/2, so J_q M = J_theta).
class ReprojectionCost : public ceres::SizedCostFunction<2, 7, 7, 1> {
 public:
  explicit ReprojectionCost(const ReprojectionFactor& f, const Eigen::Vector2d& obs_i,
                            const Eigen::Vector2d& obs_j, const CameraExtrinsics& cam0,
                            const CameraExtrinsics& cam_j, double weight);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d f_i_, t_bc0_, t_bcj_;
  Eigen::Matrix3d R_bc0_, R_cjb_;
  Eigen::Vector2d obs_j_;
  double weight_;
};

// The anchor frame's own right-camera observation: only the inverse depth is free.
class StereoFactor {
 public:
  StereoFactor(const Eigen::Vector2d& obs_left, const Eigen::Vector2d& obs_right,
               const CameraExtrinsics& cam0, const CameraExtrinsics& cam1, double weight);
  static ceres::CostFunction* Create(const Eigen::Vector2d& obs_left,
                                     const Eigen::Vector2d& obs_right, const CameraExtrinsics& cam0,
                                     const CameraExtrinsics& cam1, double weight);

  template <typename T>
  bool operator()(const T* rho, T* out) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    const V3 f(T(obs_left_.x()), T(obs_left_.y()), T(1.0));
    const V3 P = q_c1_c0_.cast<T>() * f + t_c1_c0_.cast<T>() * rho[0];
    out[0] = T(weight_) * (P.x() / P.z() - T(obs_right_.x()));
    out[1] = T(weight_) * (P.y() / P.z() - T(obs_right_.y()));
    return true;
  }

 private:
  Eigen::Vector2d obs_left_, obs_right_;
  Eigen::Quaterniond q_c1_c0_;
  Eigen::Vector3d t_c1_c0_;
  double weight_;
};

}  // namespace mapdelta::vio

#include "mapdelta/vio/factors.hpp"

namespace mapdelta::vio {
namespace {

// d(q * [0.5 delta, 1]) / d(delta) at delta = 0, rows (x, y, z, w).
Eigen::Matrix<double, 4, 3> QuaternionPlusJacobian(const double* q_xyzw) {
  const Eigen::Vector3d v(q_xyzw[0], q_xyzw[1], q_xyzw[2]);
  const double w = q_xyzw[3];
  Eigen::Matrix<double, 4, 3> J;
  J.topRows<3>() = 0.5 * (w * Eigen::Matrix3d::Identity() + Skew(v));
  J.bottomRows<1>() = -0.5 * v.transpose();
  return J;
}

}  // namespace

bool PoseManifold::Plus(const double* x, const double* delta, double* out) const {
  Eigen::Map<const Eigen::Vector3d> p(x), dp(delta), dtheta(delta + 3);
  Eigen::Map<const Eigen::Quaterniond> q(x + 3);
  Eigen::Map<Eigen::Vector3d>{out} = p + dp;
  Eigen::Map<Eigen::Quaterniond>{out + 3} = (q * ExpQuaternion(dtheta)).normalized();
  return true;
}

bool PoseManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topLeftCorner<3, 3>().setIdentity();
  J.bottomRightCorner<4, 3>() = QuaternionPlusJacobian(x + 3);
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* out) const {
  Eigen::Map<const Eigen::Quaterniond> qy(y + 3), qx(x + 3);
  Eigen::Map<Eigen::Vector3d>{out} =
      Eigen::Map<const Eigen::Vector3d>(y) - Eigen::Map<const Eigen::Vector3d>(x);
  Eigen::Map<Eigen::Vector3d>{out + 3} = LogQuaternion((qx.conjugate() * qy).normalized());
  return true;
}

bool PoseManifold::MinusJacobian(const double* x, double* jacobian) const {
  // Pseudo-inverse of the Plus Jacobian: its quaternion columns are orthogonal with norm 1/2.
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topLeftCorner<3, 3>().setIdentity();
  J.bottomRightCorner<3, 4>() = 4.0 * QuaternionPlusJacobian(x + 3).transpose();
  return true;
}

Eigen::MatrixXd ToTangentJacobian(const double* x, int ambient,
                                  const Eigen::Ref<const Eigen::MatrixXd>& J_ambient) {
  if (ambient != 7) return J_ambient;
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
  PoseManifold().PlusJacobian(x, P.data());
  return J_ambient * P;
}

Eigen::VectorXd TangentMinus(const double* y, const double* x, int ambient) {
  Eigen::VectorXd d(TangentSizeOf(ambient));
  if (ambient == 7) {
    PoseManifold().Minus(y, x, d.data());
  } else {
    for (int k = 0; k < ambient; ++k) d[k] = y[k] - x[k];
  }
  return d;
}

void PoseToArray(const SE3& T, double* pose) {
  Eigen::Map<Eigen::Vector3d>{pose} = T.translation();
  Eigen::Map<Eigen::Quaterniond>{pose + 3} = Eigen::Quaterniond(T.linear()).normalized();
}

SE3 ArrayToPose(const double* pose) {
  return MakeSE3(Eigen::Map<const Eigen::Quaterniond>(pose + 3).normalized(),
                 Eigen::Map<const Eigen::Vector3d>(pose));
}

ImuFactor::ImuFactor(const ImuPreintegration& pre, const Eigen::Vector3d& g_world)
    : dR_(pre.dR()),
      dv_(pre.dv()),
      dp_(pre.dp()),
      bg0_(pre.bg0()),
      ba0_(pre.ba0()),
      g_(g_world),
      J_R_bg_(pre.J_R_bg()),
      J_v_bg_(pre.J_v_bg()),
      J_v_ba_(pre.J_v_ba()),
      J_p_bg_(pre.J_p_bg()),
      J_p_ba_(pre.J_p_ba()),
      dt_(pre.dt()) {
  // sqrt_info^T sqrt_info = cov^-1. A tiny diagonal keeps the bias blocks invertible when
  // the random walk is zero (noiseless simulations).
  Matrix15d cov = pre.covariance();
  cov.diagonal().array() += 1e-12;
  const Matrix15d info = cov.inverse();
  sqrt_info_ = Eigen::LLT<Matrix15d>(0.5 * (info + info.transpose())).matrixU();
}

ceres::CostFunction* ImuFactor::Create(const ImuPreintegration& pre, const Eigen::Vector3d& g) {
  return new ceres::AutoDiffCostFunction<ImuFactor, 15, 7, 9, 7, 9>(new ImuFactor(pre, g));
}

ceres::CostFunction* ReprojectionFactor::Create(const Eigen::Vector2d& obs_i,
                                                const Eigen::Vector2d& obs_j,
                                                const CameraExtrinsics& cam0,
                                                const CameraExtrinsics& cam_j, double weight,
                                                bool analytic) {
  const ReprojectionFactor f(obs_i, obs_j, cam0, cam_j, weight);
  if (analytic) return new ReprojectionCost(f, obs_i, obs_j, cam0, cam_j, weight);
  return new ceres::AutoDiffCostFunction<ReprojectionFactor, 2, 7, 7, 1>(new ReprojectionFactor(f));
}

ReprojectionCost::ReprojectionCost(const ReprojectionFactor&, const Eigen::Vector2d& obs_i,
                                   const Eigen::Vector2d& obs_j, const CameraExtrinsics& cam0,
                                   const CameraExtrinsics& cam_j, double weight)
    : f_i_(obs_i.x(), obs_i.y(), 1.0),
      t_bc0_(cam0.t_body_cam),
      t_bcj_(cam_j.t_body_cam),
      R_bc0_(cam0.q_body_cam.toRotationMatrix()),
      R_cjb_(cam_j.q_body_cam.toRotationMatrix().transpose()),
      obs_j_(obs_j),
      weight_(weight) {}

bool ReprojectionCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> p_i(parameters[0]), p_j(parameters[1]);
  const Eigen::Map<const Eigen::Quaterniond> q_i(parameters[0] + 3), q_j(parameters[1] + 3);
  const double rho = parameters[2][0];
  const Eigen::Matrix3d R_i = q_i.toRotationMatrix(), R_jT = q_j.toRotationMatrix().transpose();
  const Eigen::Vector3d P_body_i = R_bc0_ * f_i_ + t_bc0_ * rho;
  const Eigen::Vector3d P_world = R_i * P_body_i + p_i * rho;
  const Eigen::Vector3d P_body_j = R_jT * (P_world - p_j * rho);
  const Eigen::Vector3d P_c = R_cjb_ * (P_body_j - t_bcj_ * rho);
  const double iz = 1.0 / P_c.z();
  residuals[0] = weight_ * (P_c.x() * iz - obs_j_.x());
  residuals[1] = weight_ * (P_c.y() * iz - obs_j_.y());
  if (!jacobians) return true;
  Eigen::Matrix<double, 2, 3> D;  // d residual / d P_c
  D << weight_ * iz, 0, -weight_ * P_c.x() * iz * iz, 0, weight_ * iz, -weight_ * P_c.y() * iz * iz;
  const Eigen::Matrix<double, 2, 3> DA = D * R_cjb_;
  const Eigen::Matrix<double, 2, 3> DB = DA * R_jT;
  using J27 = Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>>;
  auto fill_pose = [](double* out, const Eigen::Matrix<double, 2, 3>& J_p,
                      const Eigen::Matrix<double, 2, 3>& J_theta, const double* q_xyzw) {
    J27 J(out);
    J.leftCols<3>() = J_p;
    J.rightCols<4>() = 4.0 * J_theta * QuaternionPlusJacobian(q_xyzw).transpose();
  };
  if (jacobians[0]) {
    fill_pose(jacobians[0], DB * rho, -DB * R_i * Skew(P_body_i), parameters[0] + 3);
  }
  if (jacobians[1]) fill_pose(jacobians[1], -DB * rho, DA * Skew(P_body_j), parameters[1] + 3);
  if (jacobians[2]) {
    const Eigen::Vector2d J_rho = DB * (R_i * t_bc0_ + p_i - p_j) - DA * t_bcj_;
    jacobians[2][0] = J_rho.x();
    jacobians[2][1] = J_rho.y();
  }
  return true;
}

StereoFactor::StereoFactor(const Eigen::Vector2d& obs_left, const Eigen::Vector2d& obs_right,
                           const CameraExtrinsics& cam0, const CameraExtrinsics& cam1,
                           double weight)
    : obs_left_(obs_left), obs_right_(obs_right), weight_(weight) {
  // T_c1_c0 = T_c1_b * T_b_c0.
  q_c1_c0_ = cam1.q_body_cam.conjugate() * cam0.q_body_cam;
  t_c1_c0_ = cam1.q_body_cam.conjugate() * (cam0.t_body_cam - cam1.t_body_cam);
}

ceres::CostFunction* StereoFactor::Create(const Eigen::Vector2d& obs_left,
                                          const Eigen::Vector2d& obs_right,
                                          const CameraExtrinsics& cam0,
                                          const CameraExtrinsics& cam1, double weight) {
  return new ceres::AutoDiffCostFunction<StereoFactor, 2, 1>(
      new StereoFactor(obs_left, obs_right, cam0, cam1, weight));
}

}  // namespace mapdelta::vio

#pragma once
// The VIO's gauge: position and yaw about gravity are unobservable (a rigid translation and
// a rotation about the world z axis of every state change no IMU or visual residual). The
// window keeps them out of the marginalization prior and holds them with an anchor on its
// oldest frame instead (internal; pulls in Ceres).
//
// Why: a prior linearized once and kept while the states it touches are relinearized by the
// other factors ties yaw to the observable coordinates through couplings that are no longer
// true; each solve then turns the whole window a little. On noiseless paper S1_02 (15 m
// height) this was the yaw drift: 2.5 deg over 170 s, with a 10x stiffer gyro too.
#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace mapdelta::vio {

// World-z component of the small rotation taking q0 to q (the yaw error, rad).
template <typename T>
T WorldYawError(const Eigen::Quaterniond& q0, const Eigen::Quaternion<T>& q) {
  const Eigen::Quaternion<T> dq = q0.cast<T>().conjugate() * q;
  const Eigen::Matrix<T, 3, 1> dtheta_world = q0.cast<T>() * (T(2.0) * dq.vec());
  return dtheta_world.z();
}

// Holds a pose's position and yaw at given values (4 residuals, each / sigma).
ceres::CostFunction* CreateGaugeAnchor(const double* pose_now, double sigma);

// The four gauge directions (columns: translation x, y, z, yaw about world z through the
// origin) in the tangent coordinates of the blocks, at the values `x0`. Blocks by ambient
// size: 7 = pose, 9 = speed/bias (the velocity turns with yaw); any other size is left still.
Eigen::MatrixXd GaugeDirections(const std::vector<int>& ambient_sizes,
                                const std::vector<Eigen::VectorXd>& x0);

}  // namespace mapdelta::vio

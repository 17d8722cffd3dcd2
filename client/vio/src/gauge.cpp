#include "mapdelta/vio/gauge.hpp"

#include "mapdelta/vio/factors.hpp"

namespace mapdelta::vio {
namespace {

struct GaugeAnchor {
  Eigen::Vector3d p0;
  Eigen::Quaterniond q0;
  double sigma = 1e-3;
  template <typename T>
  bool operator()(const T* pose, T* r) const {
    for (int k = 0; k < 3; ++k) r[k] = (pose[k] - T(p0[k])) / T(sigma);
    r[3] =
        WorldYawError(q0, Eigen::Quaternion<T>(Eigen::Map<const Eigen::Quaternion<T>>(pose + 3))) /
        T(sigma);
    return true;
  }
};

}  // namespace

ceres::CostFunction* CreateGaugeAnchor(const double* pose_now, double sigma) {
  auto* anchor = new GaugeAnchor;
  anchor->p0 = Eigen::Map<const Eigen::Vector3d>(pose_now);
  anchor->q0 = Eigen::Map<const Eigen::Quaterniond>(pose_now + 3);
  anchor->sigma = sigma;
  return new ceres::AutoDiffCostFunction<GaugeAnchor, 4, 7>(anchor);
}

Eigen::MatrixXd GaugeDirections(const std::vector<int>& ambient_sizes,
                                const std::vector<Eigen::VectorXd>& x0) {
  int n = 0;
  for (int size : ambient_sizes) n += TangentSizeOf(size);
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(n, 4);
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  int o = 0;
  for (size_t k = 0; k < ambient_sizes.size(); ++k) {
    const Eigen::VectorXd& x = x0[k];
    if (ambient_sizes[k] == 7) {
      // p -> Rz p + t: dp = t + z x p; q -> Rz q: right perturbation dtheta = R^T z.
      const Eigen::Quaterniond q = Eigen::Map<const Eigen::Quaterniond>(x.data() + 3);
      N.block<3, 3>(o, 0).setIdentity();
      N.block<3, 1>(o, 3) = z.cross(x.head<3>());
      N.block<3, 1>(o + 3, 3) = q.conjugate() * z;
    } else if (ambient_sizes[k] == 9) {
      N.block<3, 1>(o, 3) = z.cross(x.head<3>());  // v -> Rz v; biases are body-frame
    }
    o += TangentSizeOf(ambient_sizes[k]);
  }
  return N;
}

}  // namespace mapdelta::vio

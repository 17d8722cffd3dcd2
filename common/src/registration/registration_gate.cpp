#include "mapdelta/common/registration/registration_gate.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>

namespace mapdelta {
namespace {

GateDecision Reject(GateDecision decision, const std::string& reason) {
  decision.accepted = false;
  decision.reason = reason;
  return decision;
}

}  // namespace

GateDecision CheckRegistration(const RegistrationResult& result, const SE3& init_T_target_source,
                               const RegistrationGate& gate) {
  GateDecision decision;
  // Correction measured at the source centroid: independent of where the source frame's
  // origin happens to lie (a local cloud in map coordinates has its origin far away).
  const Eigen::Vector3d c = result.source_centroid;
  decision.correction_m = (result.T_target_source * c - init_T_target_source * c).norm();
  decision.correction_rad = RotationAngle(init_T_target_source, result.T_target_source);
  std::ostringstream why;
  if (!result.converged) {
    why << "not converged after " << result.iterations << " iterations";
    return Reject(decision, why.str());
  }
  if (result.num_inliers < gate.min_inliers) {
    why << "inliers " << result.num_inliers << " < min_inliers " << gate.min_inliers;
    return Reject(decision, why.str());
  }
  const double fraction =
      result.num_source_points == 0
          ? 0.0
          : static_cast<double>(result.num_inliers) / static_cast<double>(result.num_source_points);
  if (fraction < gate.min_inlier_fraction) {
    why << "inlier fraction " << fraction << " < min_inlier_fraction " << gate.min_inlier_fraction;
    return Reject(decision, why.str());
  }
  if (!(result.fitness_m <= gate.max_fitness_m)) {
    why << "fitness " << result.fitness_m << " m > max_fitness_m " << gate.max_fitness_m;
    return Reject(decision, why.str());
  }
  if (gate.source_up) {
    const Eigen::Vector3d up = result.T_target_source.linear() * gate.source_up->normalized();
    decision.tilt_rad = std::acos(std::clamp(up.z(), -1.0, 1.0));
    if (!(decision.tilt_rad <= gate.max_tilt_rad)) {
      why << "tilt " << decision.tilt_rad * 180.0 / M_PI
          << " deg from the odometry's gravity > max_tilt " << gate.max_tilt_rad * 180.0 / M_PI
          << " deg";
      return Reject(decision, why.str());
    }
  }
  if (!(decision.correction_m <= gate.max_correction_m)) {
    why << "correction " << decision.correction_m << " m > max_correction_m "
        << gate.max_correction_m;
    return Reject(decision, why.str());
  }
  if (!(decision.correction_rad <= gate.max_correction_rad)) {
    why << "rotation correction " << decision.correction_rad << " rad > max_correction_rad "
        << gate.max_correction_rad;
    return Reject(decision, why.str());
  }
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(result.covariance);
  if (!result.covariance.allFinite() || !(eig.eigenvalues().minCoeff() > 0)) {
    return Reject(decision, "covariance is not finite and positive definite");
  }
  decision.accepted = true;
  decision.reason = "accepted";
  return decision;
}

}  // namespace mapdelta

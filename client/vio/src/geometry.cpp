#include "mapdelta/vio/geometry.hpp"

#include <Eigen/Dense>
#include <cmath>

namespace mapdelta::vio {

std::optional<Eigen::Vector3d> TriangulateRays(const std::vector<Ray>& rays, double min_angle_rad) {
  if (rays.size() < 2) return std::nullopt;
  // Minimize sum of squared distances to the rays: sum (I - d d^T) (X - o) = 0.
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double max_angle = 0;
  const Eigen::Vector3d d0 = rays.front().direction.normalized();
  for (const auto& ray : rays) {
    const Eigen::Vector3d d = ray.direction.normalized();
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    A += P;
    b += P * ray.origin;
    max_angle = std::max(max_angle, std::acos(std::clamp(d.dot(d0), -1.0, 1.0)));
  }
  if (max_angle < min_angle_rad) return std::nullopt;
  const Eigen::Vector3d X = A.ldlt().solve(b);
  if (!X.allFinite()) return std::nullopt;
  for (const auto& ray : rays) {
    if ((X - ray.origin).dot(ray.direction) <= 0) return std::nullopt;  // behind a camera
  }
  return X;
}

std::optional<Eigen::Vector3d> TriangulateStereo(const Eigen::Vector2d& left,
                                                 const Eigen::Vector2d& right,
                                                 const SE3& T_cam0_cam1) {
  const Ray r0{Eigen::Vector3d::Zero(), Eigen::Vector3d(left.x(), left.y(), 1.0)};
  const Ray r1{T_cam0_cam1.translation(),
               T_cam0_cam1.linear() * Eigen::Vector3d(right.x(), right.y(), 1.0)};
  // Far points have tiny ray angles; still useful for PnP rotation, so allow 1e-4 rad.
  return TriangulateRays({r0, r1}, 1e-4);
}

}  // namespace mapdelta::vio

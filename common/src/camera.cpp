#include "mapdelta/common/camera.hpp"

#include <cmath>
#include <sstream>

#include "mapdelta/common/error.hpp"

namespace mapdelta {

std::optional<Eigen::Vector2d> PinholeCamera::Project(const Eigen::Vector3d& p_cam) const {
  if (p_cam.z() <= 1e-9) return std::nullopt;
  const double u = fx * p_cam.x() / p_cam.z() + cx;
  const double v = fy * p_cam.y() / p_cam.z() + cy;
  if (!InImage(u, v)) return std::nullopt;
  return Eigen::Vector2d(u, v);
}

Eigen::Vector3d PinholeCamera::BackProject(double u, double v, double z) const {
  return {(u - cx) / fx * z, (v - cy) / fy * z, z};
}

bool PinholeCamera::InImage(double u, double v) const {
  return u >= 0.0 && v >= 0.0 && u < width && v < height;
}

void PinholeCamera::Validate() const {
  std::ostringstream problems;
  if (width <= 0) problems << " width must be > 0 (got " << width << ");";
  if (height <= 0) problems << " height must be > 0 (got " << height << ");";
  if (!(std::isfinite(fx) && fx > 0)) problems << " fx must be a positive number;";
  if (!(std::isfinite(fy) && fy > 0)) problems << " fy must be a positive number;";
  if (!std::isfinite(cx)) problems << " cx must be finite;";
  if (!std::isfinite(cy)) problems << " cy must be finite;";
  const std::string text = problems.str();
  if (!text.empty()) throw Error(ErrorCode::kInvalidArgument, "camera:" + text);
}

}  // namespace mapdelta

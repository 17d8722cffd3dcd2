#include "mapdelta/common/precise_cloud.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mapdelta {

size_t RemoveNonFinite(PrecisePointCloud* cloud) {
  const size_t before = cloud->size();
  std::erase_if(*cloud, [](const PrecisePoint& p) { return !p.allFinite(); });
  return before - cloud->size();
}

PointCloud ToFloat(const PrecisePointCloud& cloud) {
  PointCloud out;
  out.reserve(cloud.size());
  for (const auto& p : cloud) out.push_back(p.cast<float>());
  return out;
}

Eigen::Vector3d ChooseLocalOrigin(const PrecisePointCloud& cloud, double bound_m, double step_m) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& p : cloud) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (int a = 0; a < 3 && !cloud.empty(); ++a) {
    if (std::max(std::abs(lo[a]), std::abs(hi[a])) <= bound_m) continue;
    const double step = a < 2 ? step_m : 1.0;
    origin[a] = std::floor((lo[a] + hi[a]) / 2 / step) * step;
  }
  return origin;
}

}  // namespace mapdelta

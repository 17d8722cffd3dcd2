#include "mapdelta/common/point_cloud.hpp"

#include <algorithm>

namespace mapdelta {

PointCloud Transform(const PointCloud& cloud, const SE3& T_dst_src) {
  const Eigen::Matrix3f R = T_dst_src.linear().cast<float>();
  const Eigen::Vector3f t = T_dst_src.translation().cast<float>();
  PointCloud out;
  out.reserve(cloud.size());
  for (const auto& p : cloud) out.emplace_back(R * p + t);
  return out;
}

PointCloud Crop(const PointCloud& cloud, const AxisAlignedBox& box) {
  PointCloud out;
  std::copy_if(cloud.begin(), cloud.end(), std::back_inserter(out),
               [&](const Point& p) { return box.Contains(p); });
  return out;
}

AxisAlignedBox Bounds(const PointCloud& cloud) {
  AxisAlignedBox box;
  if (cloud.empty()) return box;
  box.min = box.max = cloud.front();
  for (const auto& p : cloud) {
    box.min = box.min.cwiseMin(p);
    box.max = box.max.cwiseMax(p);
  }
  return box;
}

size_t RemoveNonFinite(PointCloud* cloud) {
  const size_t before = cloud->size();
  std::erase_if(*cloud, [](const Point& p) { return !p.allFinite(); });
  return before - cloud->size();
}

}  // namespace mapdelta

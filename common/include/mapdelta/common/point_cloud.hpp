#pragma once
// The cloud type shared by every stage: plain xyz points in metres, no PCL in the header
// (PCL headers are slow to compile; PCL stays inside .cpp files).
#include <Eigen/Core>
#include <vector>

#include "mapdelta/common/pose.hpp"

namespace mapdelta {

using Point = Eigen::Vector3f;
using PointCloud = std::vector<Point>;

struct AxisAlignedBox {
  Eigen::Vector3f min = Eigen::Vector3f::Constant(0);
  Eigen::Vector3f max = Eigen::Vector3f::Constant(0);
  bool Contains(const Point& p) const {
    return (p.array() >= min.array()).all() && (p.array() < max.array()).all();
  }
};

PointCloud Transform(const PointCloud& cloud, const SE3& T_dst_src);
PointCloud Crop(const PointCloud& cloud, const AxisAlignedBox& box);
AxisAlignedBox Bounds(const PointCloud& cloud);  // empty cloud -> zero box
// Drops points with non-finite coordinates; returns how many were dropped.
size_t RemoveNonFinite(PointCloud* cloud);

}  // namespace mapdelta

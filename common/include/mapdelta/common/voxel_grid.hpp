#pragma once
#include <cstdint>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

// Replaces the points in each cubic voxel of edge leaf_m by their centroid. Our own hash-based
// grid rather than pcl::VoxelGrid: PCL's overflows its index on large extents with small leaves
// (a 250 m scene at 0.05 m), and the hash version needs no PCL conversion.
PointCloud VoxelDownsample(const PointCloud& cloud, float leaf_m);
// The same, also giving how many input points each output voxel replaced (counts[i] for out[i]).
PointCloud VoxelDownsample(const PointCloud& cloud, float leaf_m, std::vector<uint32_t>* counts);

}  // namespace mapdelta

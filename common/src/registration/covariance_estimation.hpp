#pragma once
// Per-point plane-regularized covariances for GICP, two neighbourhood definitions:
//  - k nearest neighbours from the k-d tree (exact; ~2 us per point for k = 20);
//  - a voxel-hash block: the points in the 3x3x3 cells around the point's cell. Block moments
//    (count, sum, sum of outer products) are accumulated once per occupied cell and shared by
//    the points in that cell, so the cost is O(N) plus 27 hash look-ups per occupied cell.
//    Cells whose block holds fewer than kMinBlockPoints points fall back to k nearest.
#include <Eigen/Core>
#include <vector>

#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta::detail {

inline constexpr size_t kMinBlockPoints = 6;

std::vector<Eigen::Matrix3f> CovariancesKNearest(const PointCloud& points,
                                                 const NeighborIndex& index, size_t k,
                                                 int num_threads);
std::vector<Eigen::Matrix3f> CovariancesVoxelBlock(const PointCloud& points,
                                                   const NeighborIndex& index, double cell_m,
                                                   size_t k, int num_threads);

}  // namespace mapdelta::detail

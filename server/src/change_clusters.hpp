#pragma once
// Change clusters from a tile's classified change points (issue #20): the points of one kind
// linked when closer than link_m (single linkage, so a wall of new points is one cluster however
// long), each cluster with its box, centroid, voxel keys (voxel_m, for matching across commits)
// and per-session evidence counted over its points.
#include <array>
#include <map>
#include <vector>

#include "blob_codec.hpp"
#include "mapdelta/server/states.hpp"

namespace mapdelta::server {

// Over a cluster's points: how many a session observed, and how many of those it supports.
struct SessionEvidence {
  int64_t observed = 0, supported = 0;
};

struct ExtractedCluster {
  ClusterKind kind = ClusterKind::kNew;
  int64_t point_count = 0;
  std::array<double, 3> min{}, max{}, centroid{};
  std::vector<VoxelKey> voxels;                   // sorted, unique
  std::map<int64_t, SessionEvidence> by_session;  // every session that observed a point
};

// Clusters in a deterministic order (kind, then their smallest voxel key).
std::vector<ExtractedCluster> ExtractClusters(const std::vector<ChangePoint>& changes,
                                              double link_m, double voxel_m);

VoxelKey VoxelOf(const Point& p, double voxel_m);
// |a ∩ b| of two sorted key lists.
int64_t OverlapCount(const std::vector<VoxelKey>& a, const std::vector<VoxelKey>& b);

}  // namespace mapdelta::server

#include "change_clusters.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "mapdelta/common/neighbor_index.hpp"

namespace mapdelta::server {
namespace {

// Union-find over point indices, path halving.
struct Components {
  explicit Components(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  size_t Find(size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void Join(size_t a, size_t b) {
    a = Find(a);
    b = Find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<size_t> parent;
};

ExtractedCluster Summarize(const std::vector<const ChangePoint*>& points, ClusterKind kind,
                           double voxel_m) {
  ExtractedCluster c;
  c.kind = kind;
  c.point_count = static_cast<int64_t>(points.size());
  c.min = {INFINITY, INFINITY, INFINITY};
  c.max = {-INFINITY, -INFINITY, -INFINITY};
  std::array<double, 3> sum{};
  for (const ChangePoint* p : points) {
    for (int i = 0; i < 3; ++i) {
      const double v = p->position[i];
      c.min[i] = std::min(c.min[i], v);
      c.max[i] = std::max(c.max[i], v);
      sum[i] += v;
    }
    c.voxels.push_back(VoxelOf(p->position, voxel_m));
    for (int64_t s : p->observed_by) c.by_session[s].observed += 1;
    for (int64_t s : p->supported_by) c.by_session[s].supported += 1;
  }
  for (int i = 0; i < 3; ++i) c.centroid[i] = sum[i] / static_cast<double>(points.size());
  std::sort(c.voxels.begin(), c.voxels.end());
  c.voxels.erase(std::unique(c.voxels.begin(), c.voxels.end()), c.voxels.end());
  return c;
}

std::vector<ExtractedCluster> ClustersOfKind(const std::vector<ChangePoint>& changes,
                                             ChangeKind kind, double link_m, double voxel_m) {
  std::vector<const ChangePoint*> points;
  PointCloud cloud;
  for (const ChangePoint& c : changes) {
    if (c.kind != kind) continue;
    points.push_back(&c);
    cloud.push_back(c.position);
  }
  std::vector<ExtractedCluster> out;
  if (points.empty()) return out;
  const NeighborIndex index(cloud);
  Components components(points.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    for (size_t j : index.RadiusSearch(cloud[i], static_cast<float>(link_m))) components.Join(i, j);
  }
  std::map<size_t, std::vector<const ChangePoint*>> by_root;  // root = smallest index: stable
  for (size_t i = 0; i < points.size(); ++i) by_root[components.Find(i)].push_back(points[i]);
  const ClusterKind k = kind == ChangeKind::kNew ? ClusterKind::kNew : ClusterKind::kRemoved;
  for (const auto& [root, members] : by_root) out.push_back(Summarize(members, k, voxel_m));
  std::sort(out.begin(), out.end(), [](const ExtractedCluster& a, const ExtractedCluster& b) {
    return a.voxels.front() < b.voxels.front();
  });
  return out;
}

}  // namespace

VoxelKey VoxelOf(const Point& p, double voxel_m) {
  return {static_cast<int32_t>(std::floor(p.x() / voxel_m)),
          static_cast<int32_t>(std::floor(p.y() / voxel_m)),
          static_cast<int32_t>(std::floor(p.z() / voxel_m))};
}

int64_t OverlapCount(const std::vector<VoxelKey>& a, const std::vector<VoxelKey>& b) {
  int64_t n = 0;
  auto i = a.begin(), j = b.begin();
  while (i != a.end() && j != b.end()) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      ++n;
      ++i;
      ++j;
    }
  }
  return n;
}

std::vector<ExtractedCluster> ExtractClusters(const std::vector<ChangePoint>& changes,
                                              double link_m, double voxel_m) {
  std::vector<ExtractedCluster> out = ClustersOfKind(changes, ChangeKind::kNew, link_m, voxel_m);
  for (ExtractedCluster& c : ClustersOfKind(changes, ChangeKind::kRemoved, link_m, voxel_m)) {
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace mapdelta::server

#pragma once
// Which change cluster a change point belongs to (issue #20): the voxel keys of a tile's clusters
// in chosen states, by kind. A point is in a cluster when its voxel (lifecycle.cluster_voxel_m)
// is one of the cluster's voxels and the kinds agree; clusters in the active states do not share
// voxels of one kind, so the answer is unique. Used by the refresh's confirmed_only rule and by
// the tile change query's state filter, so both select the same points.
#include <map>
#include <set>

#include "blob_codec.hpp"
#include "mapdelta/server/states.hpp"
#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

struct ClusterRef {
  int64_t id = 0;
  ClusterState state = ClusterState::kCandidate;
};

class ClusterVoxelIndex {
 public:
  // The clusters of `tile` whose state is in `states`.
  static ClusterVoxelIndex Load(Storage& storage, const TileId& tile,
                                const std::set<ClusterState>& states, double voxel_m);

  // The cluster holding a change point of this kind at this position, or null.
  const ClusterRef* Find(ChangeKind kind, const Point& position) const;

 private:
  double voxel_m_ = 1.0;
  std::map<VoxelKey, ClusterRef> new_, removed_;
};

}  // namespace mapdelta::server

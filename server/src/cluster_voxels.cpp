#include "cluster_voxels.hpp"

#include "change_clusters.hpp"

namespace mapdelta::server {

ClusterVoxelIndex ClusterVoxelIndex::Load(Storage& storage, const TileId& tile,
                                          const std::set<ClusterState>& states, double voxel_m) {
  constexpr int64_t kMaxClustersPerTile = 100000;  // a tile holds far fewer
  const Rect one{double(tile.ix()), double(tile.iy()), double(tile.ix()), double(tile.iy())};
  ClusterVoxelIndex index;
  index.voxel_m_ = voxel_m;
  for (const ClusterState state : states) {
    int64_t total = 0;
    for (const ChangeClusterRecord& c :
         storage.clusters().List(one, state, kMaxClustersPerTile, 0, &total)) {
      auto& by_voxel = c.kind == ClusterKind::kNew ? index.new_ : index.removed_;
      for (const VoxelKey& k : DecodeVoxelKeys(c.voxels)) by_voxel[k] = {c.id, c.state};
    }
  }
  return index;
}

const ClusterRef* ClusterVoxelIndex::Find(ChangeKind kind, const Point& position) const {
  const auto& by_voxel = kind == ChangeKind::kNew ? new_ : removed_;
  const auto it = by_voxel.find(VoxelOf(position, voxel_m_));
  return it == by_voxel.end() ? nullptr : &it->second;
}

}  // namespace mapdelta::server

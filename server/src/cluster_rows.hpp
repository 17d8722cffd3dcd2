#pragma once
// The backend-independent part of change-cluster writes (change_cluster_store.hpp), inside a
// backend's open transaction: each backend implements ClusterRows (its few statements), and
// these functions do the rest the same way for all three, so the backends agree by construction
// on what a publish or an admin decision writes.
#include <vector>

#include "mapdelta/server/change_cluster_store.hpp"

namespace mapdelta::server {

// change_clusters' columns in the order both SQL backends select and read them (migration 007).
inline constexpr const char* kClusterColumns =
    "id, ix, iy, kind, state, point_count, min_x, min_y, min_z, max_x, max_y, max_z, "
    "centroid_x, centroid_y, centroid_z, voxels, evidence_json, prior_version, applied_version, "
    "created_ms, updated_ms, seq";

class ClusterRows {
 public:
  virtual ~ClusterRows() = default;
  // Serializes cluster writes until the transaction ends (PostgreSQL: the counter row's lock);
  // called before any cluster is read for writing.
  virtual void LockFeed() = 0;
  virtual int64_t NextSeq() = 0;  // the counter + 1, stored
  virtual std::vector<ChangeClusterRecord> ActiveInTile(const TileId& tile) = 0;  // by id
  virtual std::vector<SessionFacts> TileSessions(const TileId& tile) = 0;         // by id
  virtual std::optional<ChangeClusterRecord> GetCluster(int64_t id) = 0;
  virtual int64_t InsertCluster(const ChangeClusterRecord& cluster) = 0;  // returns its new id
  virtual void UpdateCluster(const ChangeClusterRecord& cluster) = 0;     // by id, whole row
  virtual void InsertTransition(const ClusterTransitionRecord& transition) = 0;
};

// Plans the tile's clusters with the lifecycle and writes the plan (new ids, next seqs).
// publication.sessions is filled here from the tile's sessions.
void ReconcileTileClusters(const ClusterLifecycle& lifecycle, ClusterRows& rows,
                           TilePublication publication);

// ChangeClusterStore::Transition's body.
std::optional<ChangeClusterRecord> TransitionCluster(ClusterRows& rows, int64_t id,
                                                     const std::vector<ClusterState>& from,
                                                     ClusterTransitionRecord transition);

}  // namespace mapdelta::server

#pragma once
// The rules of a change cluster's life (issue #20), run inside every publish of a tile's changes
// (ClusterLifecycle, change_cluster_store.hpp):
//
// Matching: the tile's new classification is cut into clusters (change_clusters.hpp). A new
// cluster takes the id of the tile's existing cluster of the same kind (candidate, confirmed or
// rejected) whose voxel keys it overlaps most (greedy, largest overlap first); one that overlaps
// none is a new candidate. An existing one overlapped only by a cluster that matched another is
// rejected as merged into it.
//
// Evidence, per cluster over its points: a session supports it if it supports at least half of
// the points it observes there, contradicts it if it observes some and supports fewer than half.
// Independent evidence = at least lifecycle.confirm_sessions sessions from at least
// lifecycle.confirm_vehicles distinct vehicle ids, or recorded on that many distinct UTC days.
//   candidate -> confirmed: independent support, more supporting than contradicting sessions.
//   candidate -> rejected: independent contradiction, more contradicting than supporting.
//   confirmed -> expired: the same contradiction (the place agrees with the prior again).
//   candidate / confirmed no longer detected while the sessions that supported it are still in
//   the tile: rejected / expired. (After a refresh reset the tile's evidence, a cluster that is
//   not detected again is left as it is: nothing has observed it since.)
//   -> applied: a refresh wrote the tile and at least half of the cluster's voxels now agree
//   with it (a new cluster's voxels hold prior points, a removed cluster's voxels hold none).
//   applied -> expired: a later classification against a prior at or after the applied version
//   finds the opposite kind of change overlapping it (the place is back as before the refresh).
// Admin decisions (MapService) bypass these rules: confirm (candidate or rejected) and reject
// (candidate or confirmed).
#include "mapdelta/server/change_cluster_store.hpp"
#include "mapdelta/server/config.hpp"

namespace mapdelta::server {

class ChangeLifecycle final : public ClusterLifecycle {
 public:
  explicit ChangeLifecycle(const LifecycleConfig& config) : config_(config) {}
  std::vector<ClusterUpdate> Plan(const TilePublication& publication,
                                  const std::vector<ChangeClusterRecord>& active) const override;

 private:
  std::vector<ClusterUpdate> PlanClassified(const TilePublication& publication,
                                            const std::vector<ChangeClusterRecord>& active) const;
  std::vector<ClusterUpdate> PlanRefreshed(const TilePublication& publication,
                                           const std::vector<ChangeClusterRecord>& active) const;

  LifecycleConfig config_;
};

}  // namespace mapdelta::server

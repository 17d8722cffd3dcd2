#include "cluster_rows.hpp"

#include <algorithm>

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {
namespace {

// Writes one planned cluster and its transitions; the cluster's seq becomes its last one's.
void WriteUpdate(ClusterRows& rows, ClusterUpdate update) {
  ChangeClusterRecord& c = update.cluster;
  if (c.id == 0) {
    if (update.transitions.empty()) {
      throw Error(ErrorCode::kInternal, "change clusters: a new cluster without its creation");
    }
    c.seq = 0;  // set below, once the transitions have their numbers
    c.id = rows.InsertCluster(c);
  }
  for (ClusterTransitionRecord& t : update.transitions) {
    t.seq = rows.NextSeq();
    t.cluster_id = c.id;
    c.seq = t.seq;
    rows.InsertTransition(t);
  }
  rows.UpdateCluster(c);
}

}  // namespace

void ReconcileTileClusters(const ClusterLifecycle& lifecycle, ClusterRows& rows,
                           TilePublication publication) {
  rows.LockFeed();
  publication.sessions = rows.TileSessions(publication.tile);
  const std::vector<ChangeClusterRecord> active = rows.ActiveInTile(publication.tile);
  for (ClusterUpdate& update : lifecycle.Plan(publication, active)) {
    const bool known = update.cluster.id == 0 ||
                       std::any_of(active.begin(), active.end(),
                                   [&](const auto& a) { return a.id == update.cluster.id; });
    if (!known || update.cluster.tile != publication.tile) {
      throw Error(ErrorCode::kInternal, "change clusters: the plan for tile " +
                                            publication.tile.ToString() +
                                            " updates a cluster that is not one of its own");
    }
    WriteUpdate(rows, std::move(update));
  }
}

std::optional<ChangeClusterRecord> TransitionCluster(ClusterRows& rows, int64_t id,
                                                     const std::vector<ClusterState>& from,
                                                     ClusterTransitionRecord transition) {
  rows.LockFeed();
  std::optional<ChangeClusterRecord> cluster = rows.GetCluster(id);
  if (!cluster) return std::nullopt;
  if (std::find(from.begin(), from.end(), cluster->state) == from.end()) {
    throw Error(ErrorCode::kConflict,
                "cluster " + std::to_string(id) + " is " + std::string(ToString(cluster->state)) +
                    ", cannot become " + std::string(ToString(transition.to)));
  }
  transition.from = cluster->state;
  cluster->state = transition.to;
  cluster->updated_ms = transition.at_ms;
  ClusterUpdate update{*cluster, {transition}};
  WriteUpdate(rows, update);
  return rows.GetCluster(id);
}

}  // namespace mapdelta::server

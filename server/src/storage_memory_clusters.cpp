// In-memory change clusters: the ClusterRows of cluster_rows.hpp over a copy of the tables (a
// publish or an admin decision swaps the copy in only when everything succeeded), and the
// cluster store's reads.
#include "cluster_rows.hpp"
#include "storage_memory.hpp"

namespace mapdelta::server {
namespace {

class MemoryClusterRows final : public ClusterRows {
 public:
  MemoryClusterRows(const MemoryTables& t, MemoryClusterTables& c) : t_(t), c_(c) {}
  void LockFeed() override {}  // the tables' mutex is held
  int64_t NextSeq() override { return ++c_.last_seq; }
  std::vector<ChangeClusterRecord> ActiveInTile(const TileId& tile) override {
    std::vector<ChangeClusterRecord> out;
    for (const auto& [id, c] : c_.clusters) {
      if (c.tile == tile && c.state != ClusterState::kExpired) out.push_back(c);
    }
    return out;
  }
  std::vector<SessionFacts> TileSessions(const TileId& tile) override {
    std::vector<SessionFacts> out;
    auto state = t_.tile_states.find(tile);
    if (state == t_.tile_states.end()) return out;
    for (int64_t id : state->second.sessions) {
      auto s = t_.sessions.find(id);
      if (s == t_.sessions.end()) continue;
      out.push_back({id, s->second.record.vehicle_id, s->second.record.created_ms,
                     s->second.record.job_id, s->second.record.localization_weight.value_or(1.0)});
    }
    return out;
  }
  std::optional<ChangeClusterRecord> GetCluster(int64_t id) override {
    auto it = c_.clusters.find(id);
    if (it == c_.clusters.end()) return std::nullopt;
    return it->second;
  }
  int64_t InsertCluster(const ChangeClusterRecord& cluster) override {
    const int64_t id = NextId(c_.clusters);
    c_.clusters[id] = cluster;
    c_.clusters[id].id = id;
    return id;
  }
  void UpdateCluster(const ChangeClusterRecord& cluster) override {
    c_.clusters[cluster.id] = cluster;
  }
  void InsertTransition(const ClusterTransitionRecord& transition) override {
    c_.transitions[transition.seq] = transition;
  }

 private:
  const MemoryTables& t_;
  MemoryClusterTables& c_;
};

}  // namespace

std::optional<MemoryClusterTables> PlanClustersInMemory(
    const MemoryTables& t, const ClusterLifecycle* lifecycle,
    const std::vector<TilePublication>& publications) {
  if (!lifecycle) return std::nullopt;
  MemoryClusterTables copy = t.change_clusters;
  MemoryClusterRows rows(t, copy);
  for (const TilePublication& p : publications) ReconcileTileClusters(*lifecycle, rows, p);
  return copy;
}

std::optional<ChangeClusterRecord> MemoryClusterStore::Get(int64_t id) {
  auto lock = Lock();
  auto it = t().change_clusters.clusters.find(id);
  if (it == t().change_clusters.clusters.end()) return std::nullopt;
  return it->second;
}

std::vector<ClusterTransitionRecord> MemoryClusterStore::History(int64_t id) {
  auto lock = Lock();
  std::vector<ClusterTransitionRecord> out;
  for (const auto& [seq, tr] : t().change_clusters.transitions) {
    if (tr.cluster_id == id) out.push_back(tr);
  }
  return out;
}

std::vector<ChangeClusterRecord> MemoryClusterStore::Feed(int64_t since, int64_t limit) {
  auto lock = Lock();
  std::map<int64_t, const ChangeClusterRecord*> by_seq;
  for (const auto& [id, c] : t().change_clusters.clusters) {
    if (c.seq > since) by_seq[c.seq] = &c;
  }
  std::vector<ChangeClusterRecord> out;
  for (const auto& [seq, c] : by_seq) {
    if (static_cast<int64_t>(out.size()) >= limit) break;
    out.push_back(*c);
  }
  return out;
}

int64_t MemoryClusterStore::LastSeq() {
  auto lock = Lock();
  return t().change_clusters.last_seq;
}

std::vector<ChangeClusterRecord> MemoryClusterStore::List(const std::optional<Rect>& rect,
                                                          std::optional<ClusterState> state,
                                                          int64_t limit, int64_t offset,
                                                          int64_t* total) {
  auto lock = Lock();
  std::vector<ChangeClusterRecord> out;
  *total = 0;
  for (const auto& [id, c] : t().change_clusters.clusters) {
    if ((rect && !InTileRect(c.tile, *rect)) || (state && c.state != *state)) continue;
    const int64_t index = (*total)++;
    if (index < offset || index >= offset + limit) continue;
    out.push_back(c);
  }
  return out;
}

std::optional<ChangeClusterRecord> MemoryClusterStore::Transition(
    int64_t id, const std::vector<ClusterState>& from, ClusterTransitionRecord transition) {
  auto lock = Lock();
  MemoryClusterTables copy = t().change_clusters;
  MemoryClusterRows rows(t(), copy);
  std::optional<ChangeClusterRecord> out = TransitionCluster(rows, id, from, transition);
  t().change_clusters = std::move(copy);
  return out;
}

}  // namespace mapdelta::server

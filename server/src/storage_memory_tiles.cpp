// In-memory tile store: per-tile aggregation, classification, refresh, settings.
#include "mapdelta/common/error.hpp"
#include "storage_memory.hpp"

namespace mapdelta::server {

namespace {

// The checks a SQL backend's foreign keys make on job_tiles rows.
void RequireJob(const MemoryTables& t, int64_t job_id, const char* what) {
  if (!t.jobs.count(job_id)) {
    throw Error(ErrorCode::kConflict,
                std::string(what) + ": job " + std::to_string(job_id) + " does not exist");
  }
}

}  // namespace

std::optional<TileStateRecord> MemoryTileStore::GetState(const TileId& tile) {
  auto lock = Lock();
  auto it = t().tile_states.find(tile);
  if (it == t().tile_states.end()) return std::nullopt;
  return it->second;
}

std::vector<TileId> MemoryTileStore::ListAggregated(const std::optional<Rect>& rect) {
  auto lock = Lock();
  std::vector<TileId> out;
  for (const auto& [tile, state] : t().tile_states) {
    if (!rect || InTileRect(tile, *rect)) out.push_back(tile);
  }
  return out;
}

void MemoryTileStore::ApplyUpdates(int64_t job_id, const std::vector<TileStateRecord>& states,
                                   int64_t now_ms) {
  auto lock = Lock();
  RequireJob(t(), job_id, "tile updates");
  for (const TileStateRecord& state : states) {
    for (int64_t session : state.sessions) {
      if (!t().sessions.count(session)) {
        throw Error(ErrorCode::kConflict, "tile " + state.tile.ToString() + ": session " +
                                              std::to_string(session) + " does not exist");
      }
    }
  }
  for (const TileStateRecord& state : states) {
    TileStateRecord stored = state;
    stored.updated_ms = now_ms;
    t().tile_states[state.tile] = std::move(stored);
    t().job_tiles[job_id].insert(state.tile.ToString());
  }
}

void MemoryTileStore::ApplyChanges(int64_t job_id, const std::vector<TileChangesRecord>& changes) {
  auto lock = Lock();
  if (job_id > 0) RequireJob(t(), job_id, "tile changes");
  std::vector<TilePublication> published;
  for (const TileChangesRecord& c : changes) {
    published.push_back({c.tile, job_id, c.updated_ms, &c, nullptr, 0, {}});
  }
  std::optional<MemoryClusterTables> clusters =
      PlanClustersInMemory(t(), lifecycle_.get(), published);
  for (const TileChangesRecord& c : changes) {
    t().tile_changes[c.tile] = c;
    if (job_id > 0) t().job_tiles[job_id].insert(c.tile.ToString());
  }
  if (clusters) t().change_clusters = std::move(*clusters);
}

std::optional<TileChangesRecord> MemoryTileStore::GetChanges(const TileId& tile) {
  auto lock = Lock();
  auto it = t().tile_changes.find(tile);
  if (it == t().tile_changes.end()) return std::nullopt;
  return it->second;
}

std::vector<TileChangesRecord> MemoryTileStore::ListChanged(const Rect& rect, double min_confidence,
                                                            int64_t limit, int64_t offset,
                                                            int64_t* total) {
  auto lock = Lock();
  std::vector<TileChangesRecord> out;
  *total = 0;
  for (const auto& [tile, c] : t().tile_changes) {
    if (!InTileRect(tile, rect) || c.max_confidence < min_confidence ||
        c.new_count + c.removed_count <= 0) {
      continue;
    }
    const int64_t index = (*total)++;
    if (index < offset || (limit >= 0 && index >= offset + limit)) continue;
    TileChangesRecord listed = c;
    listed.changes.clear();
    out.push_back(std::move(listed));
  }
  return out;
}

int64_t MemoryTileStore::ApplyRefresh(int64_t job_id, const PriorVersionRecord& meta,
                                      const std::vector<RefreshTileWrite>& tiles,
                                      const std::string& result_json, int64_t now_ms) {
  auto lock = Lock();
  const int64_t previous = t().prior_versions.empty() ? 0 : t().prior_versions.rbegin()->first;
  if (previous == 0)
    throw Error(ErrorCode::kConflict, "refresh: there is no prior version to refresh");
  std::set<TileId> seen;
  for (const RefreshTileWrite& w : tiles) {
    if (!seen.insert(w.tile).second || t().refresh_log.count({job_id, w.tile.ToString()})) {
      throw Error(ErrorCode::kConflict, "refresh: tile " + w.tile.ToString() + " written twice");
    }
  }
  const int64_t version = previous + 1;
  std::vector<TilePublication> published;
  for (const RefreshTileWrite& w : tiles) {
    published.push_back({w.tile, job_id, now_ms, nullptr, &w, version, {}});
  }
  std::optional<MemoryClusterTables> clusters =
      PlanClustersInMemory(t(), lifecycle_.get(), published);
  PriorVersionRecord record;
  record.version = version;
  record.created_ms = now_ms;
  record.source = PriorSource::kRefresh;
  record.parent = previous;
  record.note = meta.note;
  record.job_id = job_id;
  t().prior_versions[version] = record;
  for (const RefreshTileWrite& w : tiles) {
    PriorTileRecord row;
    row.tile = w.tile;
    row.version = version;
    row.point_count = w.point_count;
    row.points = w.points;
    t().prior_tiles[w.tile][version] = std::move(row);
    // The merged changes are now part of the prior: the tile starts aggregating afresh.
    t().tile_states.erase(w.tile);
    t().tile_changes.erase(w.tile);
    RefreshTileWrite logged = w;
    logged.points.clear();
    t().refresh_log[{job_id, w.tile.ToString()}] = std::move(logged);
  }
  if (auto job = t().jobs.find(job_id); job != t().jobs.end()) {
    job->second.progress = 0.9;
    job->second.message =
        "prior version " + std::to_string(version) + " created; reclassifying neighbours";
    job->second.result_json = result_json;
  }
  if (clusters) t().change_clusters = std::move(*clusters);
  return version;
}

std::optional<std::string> MemoryTileStore::GetSetting(const std::string& key) {
  auto lock = Lock();
  auto it = t().settings.find(key);
  if (it == t().settings.end()) return std::nullopt;
  return it->second;
}

void MemoryTileStore::PutSetting(const std::string& key, const std::string& value) {
  auto lock = Lock();
  t().settings[key] = value;
}

}  // namespace mapdelta::server

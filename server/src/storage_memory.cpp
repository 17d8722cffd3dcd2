// In-memory storage: opening, shared helpers, the token and prior stores. The other stores are
// in storage_memory_{sessions,jobs,tiles}.cpp.
#include "storage_memory.hpp"

#include <algorithm>

#include "mapdelta/common/error.hpp"
#include "mapdelta/server/memory_storage.hpp"

namespace mapdelta::server {

std::unique_ptr<Storage> OpenMemoryStorage() {
  auto tables = std::make_shared<MemoryTables>();
  Storage::Stores stores;
  stores.tokens = std::make_unique<MemoryTokenStore>(tables);
  stores.priors = std::make_unique<MemoryPriorStore>(tables);
  stores.sessions = std::make_unique<MemorySessionStore>(tables);
  stores.jobs = std::make_unique<MemoryJobStore>(tables);
  stores.tiles = std::make_unique<MemoryTileStore>(tables);
  stores.clusters = std::make_unique<MemoryClusterStore>(tables);
  stores.coverage = std::make_unique<MemoryCoverageStore>(tables);
  return std::make_unique<Storage>(std::move(stores));
}

bool InTileRect(const TileId& tile, const Rect& rect) {
  return tile.ix() >= static_cast<int64_t>(rect.min_x) &&
         tile.ix() <= static_cast<int64_t>(rect.max_x) &&
         tile.iy() >= static_cast<int64_t>(rect.min_y) &&
         tile.iy() <= static_cast<int64_t>(rect.max_y);
}

int64_t InsertQueuedJob(MemoryTables& t, JobType type, const std::string& params_json,
                        int64_t now_ms) {
  JobRecord job;
  job.id = NextId(t.jobs);
  job.type = type;
  job.state = JobState::kQueued;
  job.params_json = params_json;
  job.created_ms = now_ms;
  t.jobs[job.id] = job;
  return job.id;
}

// ---------------------------------------------------------------- tokens

void MemoryTokenStore::Insert(const TokenRecord& token, const std::string& hash) {
  auto lock = Lock();
  for (const auto& row : t().tokens) {
    if (row.record.id == token.id || row.hash == hash) {
      throw Error(ErrorCode::kConflict, "token " + token.id + ": id or hash already stored");
    }
  }
  t().tokens.push_back({token, hash});
}

std::optional<TokenRecord> MemoryTokenStore::FindActiveByHash(const std::string& hash) {
  auto lock = Lock();
  for (const auto& row : t().tokens) {
    if (row.hash == hash && !row.record.revoked_ms) return row.record;
  }
  return std::nullopt;
}

bool MemoryTokenStore::Revoke(const std::string& id, int64_t now_ms) {
  auto lock = Lock();
  for (auto& row : t().tokens) {
    if (row.record.id == id && !row.record.revoked_ms) {
      row.record.revoked_ms = now_ms;
      return true;
    }
  }
  return false;
}

std::vector<TokenRecord> MemoryTokenStore::List() {
  auto lock = Lock();
  std::vector<TokenRecord> out;
  for (const auto& row : t().tokens) out.push_back(row.record);
  std::stable_sort(out.begin(), out.end(), [](const TokenRecord& a, const TokenRecord& b) {
    return a.created_ms < b.created_ms;
  });
  return out;
}

// ---------------------------------------------------------------- prior map

namespace {

// The tile's row at a version: the greatest version <= the one asked for.
const PriorTileRecord* RowAt(const std::map<int64_t, PriorTileRecord>& rows, int64_t version) {
  auto it = rows.upper_bound(version);
  if (it == rows.begin()) return nullptr;
  return &std::prev(it)->second;
}

}  // namespace

int64_t MemoryPriorStore::CreateVersion(const PriorVersionRecord& meta,
                                        const std::vector<PriorTileRecord>& tiles,
                                        bool replace_all) {
  auto lock = Lock();
  std::set<TileId> written;
  for (const PriorTileRecord& tile : tiles) {
    if (!written.insert(tile.tile).second) {
      throw Error(ErrorCode::kConflict,
                  "prior version: tile " + tile.tile.ToString() + " given twice");
    }
  }
  if (meta.frame && t().map_frame) RequireSameFrame(*t().map_frame, *meta.frame);
  if (meta.frame && !t().map_frame) t().map_frame = meta.frame;
  const int64_t previous = t().prior_versions.empty() ? 0 : t().prior_versions.rbegin()->first;
  const int64_t version = previous + 1;
  PriorVersionRecord record = meta;
  record.frame.reset();  // the map's, not the version's (as the SQL backends store it)
  record.version = version;
  record.parent = previous > 0 ? std::optional<int64_t>(previous) : std::nullopt;
  t().prior_versions[version] = record;
  for (const PriorTileRecord& tile : tiles) {
    PriorTileRecord row = tile;
    row.version = version;
    t().prior_tiles[tile.tile][version] = std::move(row);
  }
  if (replace_all && previous > 0) {
    // Tiles that had points before but are absent now must read as empty at this version.
    for (auto& [tile, rows] : t().prior_tiles) {
      const PriorTileRecord* before = RowAt(rows, previous);
      if (written.count(tile) || !before || before->point_count == 0) continue;
      PriorTileRecord empty;
      empty.tile = tile;
      empty.version = version;
      rows[version] = empty;
    }
  }
  return version;
}

std::optional<int64_t> MemoryPriorStore::LatestVersion() {
  auto lock = Lock();
  if (t().prior_versions.empty()) return std::nullopt;
  return t().prior_versions.rbegin()->first;
}

std::optional<MapFrame> MemoryPriorStore::Frame() {
  auto lock = Lock();
  return t().map_frame;
}

std::vector<PriorVersionRecord> MemoryPriorStore::ListVersions() {
  auto lock = Lock();
  std::vector<PriorVersionRecord> out;
  for (const auto& [version, record] : t().prior_versions) out.push_back(record);
  return out;
}

std::optional<PriorTileRecord> MemoryPriorStore::GetTile(const TileId& tile, int64_t version) {
  auto lock = Lock();
  auto it = t().prior_tiles.find(tile);
  if (it == t().prior_tiles.end()) return std::nullopt;
  const PriorTileRecord* row = RowAt(it->second, version);
  if (!row) return std::nullopt;
  return *row;
}

std::vector<PriorTileRecord> MemoryPriorStore::ListTiles(const Rect& rect, int64_t version) {
  auto lock = Lock();
  std::vector<PriorTileRecord> out;
  for (const auto& [tile, rows] : t().prior_tiles) {
    const PriorTileRecord* row = InTileRect(tile, rect) ? RowAt(rows, version) : nullptr;
    if (!row || row->point_count == 0) continue;
    PriorTileRecord listed = *row;
    listed.points.clear();
    out.push_back(std::move(listed));
  }
  return out;
}

}  // namespace mapdelta::server

// In-memory per-tile work of commit jobs (JobStore::AddTileWork .. ListTileWork) and its
// publication (TileStore::PublishTileWork): the contract of the SQL backends, under the one
// mutex of the tables.
#include "mapdelta/common/error.hpp"
#include "storage_memory.hpp"

namespace mapdelta::server {
namespace {

bool Claimable(const TileWorkItem& item, int64_t now_ms) {
  return !item.done_by && (!item.lease_owner || item.lease_expires_ms.value_or(0) < now_ms);
}

bool JobRunning(const MemoryTables& t, int64_t job_id) {
  auto it = t.jobs.find(job_id);
  return it != t.jobs.end() && it->second.state == JobState::kRunning;
}

}  // namespace

void MemoryJobStore::AddTileWork(int64_t job_id, int64_t prior_version,
                                 const std::vector<TileId>& tiles) {
  auto lock = Lock();
  if (!t().jobs.count(job_id)) {
    throw Error(ErrorCode::kConflict,
                "tile work: job " + std::to_string(job_id) + " does not exist");
  }
  auto& items = t().tile_work[job_id];
  for (const TileId& tile : tiles) {
    if (items.count(tile)) continue;
    TileWorkItem item;
    item.job_id = job_id;
    item.tile = tile;
    item.prior_version = prior_version;
    items[tile].item = item;
  }
}

std::optional<TileWorkItem> MemoryJobStore::ClaimTileWork(std::optional<int64_t> job_id,
                                                          int64_t now_ms, int64_t lease_ms) {
  auto lock = Lock();
  for (auto& [id, items] : t().tile_work) {  // oldest job first, then by tile
    if ((job_id && id != *job_id) || !JobRunning(t(), id)) continue;
    for (auto& [tile, row] : items) {
      if (!Claimable(row.item, now_ms)) continue;
      row.item.claims += 1;
      row.item.lease_owner = worker_id_;
      row.item.lease_expires_ms = now_ms + lease_ms;
      return row.item;
    }
  }
  return std::nullopt;
}

bool MemoryJobStore::CompleteTileWork(const TileWorkItem& claimed,
                                      const TileChangesRecord& result) {
  auto lock = Lock();
  auto job = t().tile_work.find(claimed.job_id);
  if (job == t().tile_work.end()) return false;
  auto it = job->second.find(claimed.tile);
  if (it == job->second.end()) return false;
  TileWorkItem& item = it->second.item;
  if (item.done_by || item.claims != claimed.claims || item.lease_owner != worker_id_) return false;
  item.done_by = worker_id_;
  item.lease_owner.reset();
  item.lease_expires_ms.reset();
  item.new_count = result.new_count;
  item.removed_count = result.removed_count;
  it->second.staged = result;
  it->second.staged.tile = claimed.tile;
  it->second.staged.prior_version = item.prior_version;  // the item's, as the SQL backends copy
  return true;
}

std::vector<TileWorkItem> MemoryJobStore::ListTileWork(int64_t job_id) {
  auto lock = Lock();
  std::vector<TileWorkItem> out;
  auto job = t().tile_work.find(job_id);
  if (job == t().tile_work.end()) return out;
  for (const auto& [tile, row] : job->second) out.push_back(row.item);
  return out;
}

PublishOutcome MemoryTileStore::PublishTileWork(int64_t job_id) {
  auto lock = Lock();
  auto job = t().tile_work.find(job_id);
  if (job == t().tile_work.end() || job->second.empty()) return PublishOutcome::kNotReady;
  for (const auto& [tile, row] : job->second) {
    if (row.item.published) return PublishOutcome::kAlreadyPublished;
    if (!row.item.done_by) return PublishOutcome::kNotReady;
  }
  std::vector<TilePublication> published;
  for (const auto& [tile, row] : job->second) {
    published.push_back({tile, job_id, row.staged.updated_ms, &row.staged, nullptr, 0, {}});
  }
  if (auto clusters = PlanClustersInMemory(t(), lifecycle_.get(), published))
    t().change_clusters = std::move(*clusters);
  for (auto& [tile, row] : job->second) {
    t().tile_changes[tile] = row.staged;
    row.item.published = true;
    row.staged = TileChangesRecord{};  // the staged copy is dropped, as in SQL
  }
  return PublishOutcome::kPublished;
}

}  // namespace mapdelta::server

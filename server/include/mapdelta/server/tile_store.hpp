#pragma once
// Per-tile aggregation across sessions, per-tile classification, the refresh that merges
// changes into a new prior version, and the settings (current classification parameters).
#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "mapdelta/common/tiling.hpp"
#include "mapdelta/server/change_cluster_store.hpp"
#include "mapdelta/server/prior_store.hpp"
#include "mapdelta/server/storage_types.hpp"

namespace mapdelta::server {

struct TileStateRecord {
  TileId tile;
  Bytes aggregate;             // encoded TileAggregate
  std::set<int64_t> sessions;  // sessions aggregated into the tile (their octrees = observed)
  int64_t updated_ms = 0;
};

struct TileChangesRecord {
  TileId tile;
  int64_t prior_version = 0, new_count = 0, removed_count = 0, updated_ms = 0;
  double max_confidence = 0;
  Bytes changes;  // empty in listings
  std::string params_json;
};

struct RefreshTileWrite {
  TileId tile;
  int64_t from_version = 0, added = 0, removed = 0, point_count = 0;
  Bytes points;
};

// What TileStore::PublishTileWork did.
enum class PublishOutcome {
  kPublished,         // this call published the job's results
  kAlreadyPublished,  // an earlier call did (any worker may call it; only one publishes)
  kNotReady,          // an item is not done yet, or the job has none: nothing written
};

class TileStore {
 public:
  virtual ~TileStore() = default;
  virtual std::optional<TileStateRecord> GetState(const TileId& tile) = 0;
  // Tiles with an aggregate, in the rect if given, ordered by (ix, iy).
  virtual std::vector<TileId> ListAggregated(const std::optional<Rect>& rect) = 0;
  // One transaction for all: each tile's state (aggregate, its session set, updated_ms =
  // now_ms) and the tile recorded as done by job_id (a commit applies its whole session at
  // once: never half a session). Throws Error(kConflict), writing nothing, if the job or a
  // listed session does not exist.
  virtual void ApplyUpdates(int64_t job_id, const std::vector<TileStateRecord>& states,
                            int64_t now_ms) = 0;
  // One transaction for all: the tiles' classifications, plus each tile recorded as done by
  // job_id if job_id > 0 (Error(kConflict), nothing written, if that job does not exist).
  virtual void ApplyChanges(int64_t job_id, const std::vector<TileChangesRecord>& changes) = 0;
  // One transaction: if every work item of job_id (JobStore::AddTileWork) is done, their staged
  // results become the tiles' classifications (as ApplyChanges) and the items published (their
  // staged blobs dropped), so readers see all the commit's tiles change at once or none.
  virtual PublishOutcome PublishTileWork(int64_t job_id) = 0;
  virtual std::optional<TileChangesRecord> GetChanges(const TileId& tile) = 0;
  // Tiles in the rect with max_confidence >= min_confidence and at least one change, ordered
  // by (ix, iy), without their change blobs; *total = how many match before paging.
  virtual std::vector<TileChangesRecord> ListChanged(const Rect& rect, double min_confidence,
                                                     int64_t limit, int64_t offset,
                                                     int64_t* total) = 0;
  // One transaction: prior version latest + 1 (source "refresh", parent = latest, note from
  // meta, job_id = job_id, created_ms = now_ms) with these tiles, their aggregation and
  // changes reset, a refresh log row per tile, and result_json, progress 0.9 and a message
  // stored on the job (which stays running: the caller finishes it after reclassifying the
  // neighbours). Throws Error(kConflict), writing nothing, if a tile appears twice.
  virtual int64_t ApplyRefresh(int64_t job_id, const PriorVersionRecord& meta,
                               const std::vector<RefreshTileWrite>& tiles,
                               const std::string& result_json, int64_t now_ms) = 0;

  virtual std::optional<std::string> GetSetting(const std::string& key) = 0;
  virtual void PutSetting(const std::string& key, const std::string& value) = 0;

  // Once set, every write above that publishes tiles' changes (ApplyChanges, PublishTileWork,
  // ApplyRefresh) updates each published tile's change clusters by its Plan in the same
  // transaction (change_cluster_store.hpp); an exception from it writes nothing. Unset (the
  // CLI tools, most storage tests): no clusters. Set before the store is used by other threads.
  void SetClusterLifecycle(std::shared_ptr<const ClusterLifecycle> lifecycle) {
    lifecycle_ = std::move(lifecycle);
  }

 protected:
  std::shared_ptr<const ClusterLifecycle> lifecycle_;
};

}  // namespace mapdelta::server

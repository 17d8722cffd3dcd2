#pragma once
// In-memory implementation of the stores: plain containers under one mutex shared by the seven
// stores, so a cross-area write (commit + job, cancel + session, refresh + prior) is one
// critical section. Every write checks everything it could refuse before it changes anything,
// which is what makes each method atomic without a rollback log.
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <utility>

#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

// The change clusters' tables (kept together: a publish plans them on a copy and swaps it in,
// which makes the cluster part of a publish all or nothing).
struct MemoryClusterTables {
  std::map<int64_t, ChangeClusterRecord> clusters;
  std::map<int64_t, ClusterTransitionRecord> transitions;  // by seq
  int64_t last_seq = 0;
};

struct MemoryTables {
  struct TokenRow {
    TokenRecord record;
    std::string hash;
  };
  struct SessionRow {
    SessionRecord record;                         // keyframe_count / last_t_ns are derived on read
    std::map<int64_t, KeyframeRecord> keyframes;  // by seq
    std::optional<Bytes> observed;
  };

  std::mutex mutex;
  std::vector<TokenRow> tokens;  // insertion order
  std::map<int64_t, PriorVersionRecord> prior_versions;
  std::optional<MapFrame> map_frame;
  std::map<TileId, std::map<int64_t, PriorTileRecord>> prior_tiles;  // tile -> version -> row
  std::map<int64_t, SessionRow> sessions;
  std::map<int64_t, JobRecord> jobs;
  std::map<int64_t, std::set<std::string>> job_tiles;
  struct TileWorkRow {
    TileWorkItem item;
    TileChangesRecord staged;  // once done, until published
  };
  std::map<int64_t, std::map<TileId, TileWorkRow>> tile_work;  // job -> tile -> item
  std::map<TileId, TileStateRecord> tile_states;
  std::map<TileId, TileChangesRecord> tile_changes;
  std::map<std::pair<int64_t, std::string>, RefreshTileWrite> refresh_log;  // (job, tile)
  std::map<std::string, std::string> settings;
  MemoryClusterTables change_clusters;
  std::map<std::pair<TileId, int64_t>, CoverageRecord> coverage;  // (tile, session): ix, iy, id
};

// The clusters after publishing these tiles (ReconcileTileClusters on a copy of the tables), or
// nullopt without a lifecycle. Called under the tables' mutex, before the publish writes tiles.
std::optional<MemoryClusterTables> PlanClustersInMemory(
    const MemoryTables& t, const ClusterLifecycle* lifecycle,
    const std::vector<TilePublication>& publications);

// Next id of a table keyed by id, as SQLite's INTEGER PRIMARY KEY picks it (greatest + 1).
template <typename Row>
int64_t NextId(const std::map<int64_t, Row>& table) {
  return table.empty() ? 1 : table.rbegin()->first + 1;
}

// Whether a tile lies in a Rect of tile indices (as the SQL backends compare: integer bounds).
bool InTileRect(const TileId& tile, const Rect& rect);

// A new queued job (used by the job store and by the session store's commit).
int64_t InsertQueuedJob(MemoryTables& t, JobType type, const std::string& params_json,
                        int64_t now_ms);

// Base of the in-memory stores: access to the shared tables.
class MemoryArea {
 public:
  explicit MemoryArea(std::shared_ptr<MemoryTables> tables) : tables_(std::move(tables)) {}

 protected:
  std::unique_lock<std::mutex> Lock() { return std::unique_lock(tables_->mutex); }
  MemoryTables& t() { return *tables_; }

 private:
  std::shared_ptr<MemoryTables> tables_;
};

class MemoryTokenStore final : public TokenStore, MemoryArea {
 public:
  using MemoryArea::MemoryArea;
  void Insert(const TokenRecord& token, const std::string& hash) override;
  std::optional<TokenRecord> FindActiveByHash(const std::string& hash) override;
  bool Revoke(const std::string& id, int64_t now_ms) override;
  std::vector<TokenRecord> List() override;
};

class MemoryPriorStore final : public PriorStore, MemoryArea {
 public:
  using MemoryArea::MemoryArea;
  int64_t CreateVersion(const PriorVersionRecord& meta, const std::vector<PriorTileRecord>& tiles,
                        bool replace_all) override;
  std::optional<int64_t> LatestVersion() override;
  std::optional<MapFrame> Frame() override;
  std::vector<PriorVersionRecord> ListVersions() override;
  std::optional<PriorTileRecord> GetTile(const TileId& tile, int64_t version) override;
  std::vector<PriorTileRecord> ListTiles(const Rect& rect, int64_t version) override;
};

class MemorySessionStore final : public SessionStore, MemoryArea {
 public:
  using MemoryArea::MemoryArea;
  int64_t Create(const SessionRecord& session) override;
  std::optional<SessionRecord> Get(int64_t id) override;
  PutKeyframeOutcome PutKeyframe(int64_t session_id, const KeyframeRecord& keyframe) override;
  void ForEachKeyframe(int64_t session_id, int64_t first_seq, int64_t end_seq, bool with_depth,
                       const std::function<void(const KeyframeRecord&)>& fn) override;
  std::optional<int64_t> Commit(int64_t session_id, const std::string& params_json,
                                int64_t now_ms) override;
  void Finish(int64_t session_id, SessionState state,
              const std::optional<std::string>& registration_json, int64_t now_ms) override;
  void PutObserved(int64_t session_id, const Bytes& observed) override;
  std::optional<Bytes> GetObserved(int64_t session_id) override;
  void PutLocalization(int64_t session_id, double weight, const std::string& json) override;
};

class MemoryJobStore final : public JobStore, MemoryArea {
 public:
  using MemoryArea::MemoryArea;
  int64_t Create(JobType type, const std::string& params_json, int64_t now_ms) override;
  std::optional<JobRecord> Get(int64_t id) override;
  std::vector<JobRecord> List(int64_t limit, int64_t offset) override;
  std::optional<JobRecord> ClaimNext(int64_t now_ms, int64_t lease_ms) override;
  bool RenewLease(int64_t id, int64_t now_ms, int64_t lease_ms) override;
  void Release(int64_t id) override;
  std::optional<EarlierJob> UnfinishedBefore(int64_t job_id, int64_t now_ms,
                                             std::optional<JobType> type) override;
  const std::string& worker_id() const override { return worker_id_; }
  void UpdateProgress(int64_t id, double progress, const std::string& message) override;
  void Finish(int64_t id, JobState state, const std::string& message,
              const std::optional<std::string>& result_json, int64_t now_ms) override;
  std::optional<JobState> RequestCancel(int64_t id, int64_t now_ms) override;
  bool IsCancelRequested(int64_t id) override;
  int RequeueInterrupted(int64_t now_ms) override;
  std::set<std::string> TilesDone(int64_t job_id) override;
  void AddTileWork(int64_t job_id, int64_t prior_version,
                   const std::vector<TileId>& tiles) override;
  std::optional<TileWorkItem> ClaimTileWork(std::optional<int64_t> job_id, int64_t now_ms,
                                            int64_t lease_ms) override;
  bool CompleteTileWork(const TileWorkItem& claimed, const TileChangesRecord& result) override;
  std::vector<TileWorkItem> ListTileWork(int64_t job_id) override;
  std::vector<std::pair<JobState, int64_t>> CountByState() override;

 private:
  const std::string worker_id_ = NewWorkerId();
};

class MemoryTileStore final : public TileStore, MemoryArea {
 public:
  using MemoryArea::MemoryArea;
  std::optional<TileStateRecord> GetState(const TileId& tile) override;
  std::vector<TileId> ListAggregated(const std::optional<Rect>& rect) override;
  void ApplyUpdates(int64_t job_id, const std::vector<TileStateRecord>& states,
                    int64_t now_ms) override;
  void ApplyChanges(int64_t job_id, const std::vector<TileChangesRecord>& changes) override;
  PublishOutcome PublishTileWork(int64_t job_id) override;
  std::optional<TileChangesRecord> GetChanges(const TileId& tile) override;
  std::vector<TileChangesRecord> ListChanged(const Rect& rect, double min_confidence, int64_t limit,
                                             int64_t offset, int64_t* total) override;
  int64_t ApplyRefresh(int64_t job_id, const PriorVersionRecord& meta,
                       const std::vector<RefreshTileWrite>& tiles, const std::string& result_json,
                       int64_t now_ms) override;
  std::optional<std::string> GetSetting(const std::string& key) override;
  void PutSetting(const std::string& key, const std::string& value) override;
};

class MemoryClusterStore final : public ChangeClusterStore, MemoryArea {
 public:
  using MemoryArea::MemoryArea;
  std::optional<ChangeClusterRecord> Get(int64_t id) override;
  std::vector<ClusterTransitionRecord> History(int64_t id) override;
  std::vector<ChangeClusterRecord> Feed(int64_t since, int64_t limit) override;
  int64_t LastSeq() override;
  std::vector<ChangeClusterRecord> List(const std::optional<Rect>& rect,
                                        std::optional<ClusterState> state, int64_t limit,
                                        int64_t offset, int64_t* total) override;
  std::optional<ChangeClusterRecord> Transition(int64_t id, const std::vector<ClusterState>& from,
                                                ClusterTransitionRecord transition) override;
};

class MemoryCoverageStore final : public CoverageStore, MemoryArea {
 public:
  using MemoryArea::MemoryArea;
  void Put(const std::vector<CoverageRecord>& records) override;
  std::vector<CoverageRecord> List(const Rect& rect, int64_t since_ms, bool with_bits) override;
};

}  // namespace mapdelta::server

#pragma once
// SQLite implementation of the stores. One connection guarded by one mutex, shared by the seven
// stores: SQLite serializes writers anyway, and one connection keeps BEGIN IMMEDIATE ... COMMIT
// of different stores from interleaving.
#include <memory>
#include <mutex>

#include "mapdelta/server/storage.hpp"
#include "sqlite_db.hpp"

namespace mapdelta::server {

struct SqliteConnection {
  explicit SqliteConnection(const std::string& path) : db(path) {}
  std::mutex mutex;
  sql::Db db;
};

// Base of the SQLite stores: access to the shared connection.
class SqliteArea {
 public:
  explicit SqliteArea(std::shared_ptr<SqliteConnection> connection)
      : connection_(std::move(connection)) {}

 protected:
  std::unique_lock<std::mutex> Lock() { return std::unique_lock(connection_->mutex); }
  sql::Db& db() { return connection_->db; }

 private:
  std::shared_ptr<SqliteConnection> connection_;
};

class SqliteTokenStore final : public TokenStore, SqliteArea {
 public:
  using SqliteArea::SqliteArea;
  void Insert(const TokenRecord& token, const std::string& hash) override;
  std::optional<TokenRecord> FindActiveByHash(const std::string& hash) override;
  bool Revoke(const std::string& id, int64_t now_ms) override;
  std::vector<TokenRecord> List() override;
};

class SqlitePriorStore final : public PriorStore, SqliteArea {
 public:
  using SqliteArea::SqliteArea;
  int64_t CreateVersion(const PriorVersionRecord& meta, const std::vector<PriorTileRecord>& tiles,
                        bool replace_all) override;
  std::optional<int64_t> LatestVersion() override;
  std::optional<MapFrame> Frame() override;
  std::vector<PriorVersionRecord> ListVersions() override;
  std::optional<PriorTileRecord> GetTile(const TileId& tile, int64_t version) override;
  std::vector<PriorTileRecord> ListTiles(const Rect& rect, int64_t version) override;
};

class SqliteSessionStore final : public SessionStore, SqliteArea {
 public:
  using SqliteArea::SqliteArea;
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

class SqliteJobStore final : public JobStore, SqliteArea {
 public:
  using SqliteArea::SqliteArea;
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

class SqliteTileStore final : public TileStore, SqliteArea {
 public:
  using SqliteArea::SqliteArea;
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

 private:
  void WriteChangesLocked(const TileChangesRecord& changes);
  void MarkJobTileLocked(int64_t job_id, const TileId& tile);
};

class SqliteClusterStore final : public ChangeClusterStore, SqliteArea {
 public:
  using SqliteArea::SqliteArea;
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

class SqliteCoverageStore final : public CoverageStore, SqliteArea {
 public:
  using SqliteArea::SqliteArea;
  void Put(const std::vector<CoverageRecord>& records) override;
  std::vector<CoverageRecord> List(const Rect& rect, int64_t since_ms, bool with_bits) override;
};

// Inside the caller's open transaction: the published tile's clusters by the lifecycle
// (cluster_rows.hpp); nothing without one.
void ReconcileTileClustersSqlite(sql::Db& db, const ClusterLifecycle* lifecycle,
                                 const TilePublication& publication);

// Binds a Rect of tile indices as four integers (ix BETWEEN ? AND ? AND iy BETWEEN ? AND ?).
void BindTileRange(sql::Stmt& s, int first, const Rect& r);

}  // namespace mapdelta::server

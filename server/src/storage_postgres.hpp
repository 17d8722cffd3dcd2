#pragma once
// PostgreSQL implementation of the stores, for several server processes on one database. The seven
// stores share a pool of connections (a libpq connection serves one thread at a time); every method
// is one transaction on one connection. Where SQLite relies on its single writer, these take row
// locks (FOR UPDATE), a transaction-scoped advisory lock (prior version numbers), or skip rows
// another process holds (job claims, FOR UPDATE SKIP LOCKED).
#include <memory>
#include <string>

#include "mapdelta/server/storage.hpp"
#include "pg_pool.hpp"

namespace mapdelta::server {

// What the five stores of one Storage share: the pool, and the process's lease owner id (the job
// store claims under it, the tile store refuses writes of jobs leased to another).
struct PostgresShared {
  PostgresShared(const std::string& conninfo, int max_connections)
      : pool(conninfo, max_connections) {}
  pg::Pool pool;
  const std::string worker_id = NewWorkerId();
};

// Base of the PostgreSQL stores: access to what they share.
class PostgresArea {
 public:
  explicit PostgresArea(std::shared_ptr<PostgresShared> shared) : shared_(std::move(shared)) {}

 protected:
  pg::Pool::Lease Connect() { return shared_->pool.Acquire(); }
  const std::string& worker() const { return shared_->worker_id; }

 private:
  std::shared_ptr<PostgresShared> shared_;
};

class PostgresTokenStore final : public TokenStore, PostgresArea {
 public:
  using PostgresArea::PostgresArea;
  void Insert(const TokenRecord& token, const std::string& hash) override;
  std::optional<TokenRecord> FindActiveByHash(const std::string& hash) override;
  bool Revoke(const std::string& id, int64_t now_ms) override;
  std::vector<TokenRecord> List() override;
};

class PostgresPriorStore final : public PriorStore, PostgresArea {
 public:
  using PostgresArea::PostgresArea;
  int64_t CreateVersion(const PriorVersionRecord& meta, const std::vector<PriorTileRecord>& tiles,
                        bool replace_all) override;
  std::optional<int64_t> LatestVersion() override;
  std::optional<MapFrame> Frame() override;
  std::vector<PriorVersionRecord> ListVersions() override;
  std::optional<PriorTileRecord> GetTile(const TileId& tile, int64_t version) override;
  std::vector<PriorTileRecord> ListTiles(const Rect& rect, int64_t version) override;
};

class PostgresSessionStore final : public SessionStore, PostgresArea {
 public:
  using PostgresArea::PostgresArea;
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

class PostgresJobStore final : public JobStore, PostgresArea {
 public:
  using PostgresArea::PostgresArea;
  int64_t Create(JobType type, const std::string& params_json, int64_t now_ms) override;
  std::optional<JobRecord> Get(int64_t id) override;
  std::vector<JobRecord> List(int64_t limit, int64_t offset) override;
  std::optional<JobRecord> ClaimNext(int64_t now_ms, int64_t lease_ms) override;
  bool RenewLease(int64_t id, int64_t now_ms, int64_t lease_ms) override;
  void Release(int64_t id) override;
  std::optional<EarlierJob> UnfinishedBefore(int64_t job_id, int64_t now_ms,
                                             std::optional<JobType> type) override;
  const std::string& worker_id() const override { return worker(); }
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
};

class PostgresTileStore final : public TileStore, PostgresArea {
 public:
  using PostgresArea::PostgresArea;
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

class PostgresCoverageStore final : public CoverageStore, PostgresArea {
 public:
  using PostgresArea::PostgresArea;
  void Put(const std::vector<CoverageRecord>& records) override;
  std::vector<CoverageRecord> List(const Rect& rect, int64_t since_ms, bool with_bits) override;
};

class PostgresClusterStore final : public ChangeClusterStore, PostgresArea {
 public:
  using PostgresArea::PostgresArea;
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

// Statements the stores share, inside a caller's transaction.
namespace pg_rows {
// Takes the prior-version advisory lock (held until the transaction ends) and returns the latest
// version (0 if none): two processes creating versions at once get consecutive numbers.
int64_t LockPriorVersions(pg::Connection& c);
void InsertPriorTile(pg::Connection& c, int64_t version, const std::string& tile, int64_t ix,
                     int64_t iy, int64_t point_count, const Bytes& points);
// Appends the four integers of a Rect of tile indices (ix BETWEEN $n AND $n+1 AND iy ...).
pg::Params& AddTileRange(pg::Params& p, const Rect& r);
// Inside a job's writing transaction: throws Error(kConflict) (the caller's transaction then rolls
// back) if the job is leased to another worker than worker_id, i.e. was taken over from this one;
// FOR SHARE keeps a takeover from slipping in before the commit. A job never claimed (no lease)
// passes.
void FenceJob(pg::Connection& c, int64_t job_id, const std::string& worker_id);
// The ON CONFLICT clause of an INSERT INTO tile_changes: a tile's row is replaced whole.
extern const char* const kUpsertTileChanges;
// A publishing write with a lifecycle takes the feed's lock first, before any row of its own, so
// that publishers and admin decisions always lock in one order (no deadlock between them).
void LockClusterFeed(pg::Connection& c, const ClusterLifecycle* lifecycle);
// The published tile's clusters by the lifecycle (cluster_rows.hpp); nothing without one.
void ReconcileTileClusters(pg::Connection& c, const ClusterLifecycle* lifecycle,
                           const TilePublication& publication);
}  // namespace pg_rows

}  // namespace mapdelta::server

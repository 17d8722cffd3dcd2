#pragma once
// SQLite implementation of Storage. One connection guarded by a mutex: SQLite serializes
// writers anyway, and one connection keeps BEGIN IMMEDIATE ... COMMIT from interleaving.
#include <mutex>

#include "mapdelta/server/storage.hpp"
#include "sqlite_db.hpp"

namespace mapdelta::server {

class SqliteStorage final : public Storage {
 public:
  explicit SqliteStorage(const std::string& path);

  void InsertToken(const TokenRecord& token, const std::string& hash) override;
  std::optional<TokenRecord> FindActiveTokenByHash(const std::string& hash) override;
  bool RevokeToken(const std::string& id, int64_t now_ms) override;
  std::vector<TokenRecord> ListTokens() override;

  int64_t CreatePriorVersion(const PriorVersionRecord& meta,
                             const std::vector<PriorTileRecord>& tiles, bool replace_all) override;
  std::optional<int64_t> LatestPriorVersion() override;
  std::vector<PriorVersionRecord> ListPriorVersions() override;
  std::optional<PriorTileRecord> GetPriorTile(const TileId& tile, int64_t version) override;
  std::vector<PriorTileRecord> ListPriorTiles(const Rect& rect, int64_t version) override;

  int64_t CreateSession(const SessionRecord& session) override;
  std::optional<SessionRecord> GetSession(int64_t id) override;
  PutKeyframeOutcome PutKeyframe(int64_t session_id, const KeyframeRecord& keyframe) override;
  void ForEachKeyframe(int64_t session_id, int64_t first_seq, int64_t end_seq, bool with_depth,
                       const std::function<void(const KeyframeRecord&)>& fn) override;
  std::optional<int64_t> CommitSession(int64_t session_id, const std::string& params_json,
                                       int64_t now_ms) override;
  void FinishSession(int64_t session_id, const std::string& state,
                     const std::optional<std::string>& registration_json, int64_t now_ms) override;
  void PutSessionObserved(int64_t session_id, const Bytes& observed) override;
  std::optional<Bytes> GetSessionObserved(int64_t session_id) override;

  int64_t CreateJob(const std::string& type, const std::string& params_json,
                    int64_t now_ms) override;
  std::optional<JobRecord> GetJob(int64_t id) override;
  std::vector<JobRecord> ListJobs(int64_t limit, int64_t offset) override;
  std::optional<JobRecord> ClaimNextJob(int64_t now_ms) override;
  void UpdateJobProgress(int64_t id, double progress, const std::string& message) override;
  void FinishJob(int64_t id, const std::string& state, const std::string& message,
                 const std::optional<std::string>& result_json, int64_t now_ms) override;
  std::optional<std::string> RequestCancel(int64_t id, int64_t now_ms) override;
  bool IsCancelRequested(int64_t id) override;
  int RequeueInterruptedJobs() override;
  std::set<std::string> JobTilesDone(int64_t job_id) override;
  std::vector<std::pair<std::string, int64_t>> CountJobsByState() override;

  std::optional<TileStateRecord> GetTileState(const TileId& tile) override;
  std::vector<TileId> ListAggregatedTiles(const std::optional<Rect>& rect) override;
  void ApplyTileUpdates(int64_t job_id, const std::vector<TileStateRecord>& states,
                        int64_t now_ms) override;
  void ApplyTileChanges(int64_t job_id, const std::vector<TileChangesRecord>& changes) override;
  std::optional<TileChangesRecord> GetTileChanges(const TileId& tile) override;
  std::vector<TileChangesRecord> ListChangedTiles(const Rect& rect, double min_confidence,
                                                  int64_t limit, int64_t offset,
                                                  int64_t* total) override;
  int64_t ApplyRefresh(int64_t job_id, const PriorVersionRecord& meta,
                       const std::vector<RefreshTileWrite>& tiles, const std::string& result_json,
                       int64_t now_ms) override;

  std::optional<std::string> GetSetting(const std::string& key) override;
  void PutSetting(const std::string& key, const std::string& value) override;

 private:
  void Migrate();
  JobRecord ReadJob(sql::Stmt& s);
  void WriteChangesLocked(const TileChangesRecord& changes);
  void MarkJobTileLocked(int64_t job_id, const TileId& tile);

  std::mutex mutex_;
  sql::Db db_;
};

// Tile range of a rect on the tile grid, inclusive (used in SQL ix/iy filters).
struct TileRange {
  int64_t ix0, iy0, ix1, iy1;
};

}  // namespace mapdelta::server

#pragma once
// The storage interface the rest of the server uses. Blobs are opaque here (the service layer
// encodes them), so a second backend (PostgreSQL, tile work claimed with row locks) needs
// only this file's contract. Every method is atomic: it either applies fully or throws.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "mapdelta/common/tiling.hpp"

namespace mapdelta::server {

using Bytes = std::vector<uint8_t>;

enum class Role { kVehicle, kReader, kAdmin };
std::string_view ToString(Role role);
std::optional<Role> ParseRole(std::string_view text);

struct TokenRecord {
  std::string id, name;
  Role role = Role::kReader;
  int64_t created_ms = 0;
  std::optional<int64_t> revoked_ms;
};

struct PriorVersionRecord {
  int64_t version = 0;
  int64_t created_ms = 0;
  std::string source, note;
  std::optional<int64_t> parent, job_id;
};

struct PriorTileRecord {
  TileId tile;
  int64_t version = 0;  // the version that wrote this row (<= the version asked for)
  int64_t point_count = 0;
  Bytes points;         // empty in listings
};

struct SessionRecord {
  int64_t id = 0;
  std::string vehicle_id, camera_json, state;
  double depth_scale = 1000.0;
  int64_t created_ms = 0;
  std::optional<int64_t> committed_ms, job_id;
  std::optional<std::string> registration_json;
  int64_t keyframe_count = 0;
  int64_t last_t_ns = 0;
};

struct KeyframeRecord {
  int64_t seq = 0, t_ns = 0;
  std::string pose_json;
  std::optional<std::string> covariance_json;
  Bytes depth_png;
  std::string content_sha;
  // Derived at upload (empty = not computed): the keyframe's back-projected, voxel-filtered
  // cloud (EncodePoints) and the pipeline parameters it was computed with.
  Bytes cloud;
  std::string cloud_params;
};

enum class PutKeyframeOutcome { kStored, kIdentical, kConflict, kOutOfOrder, kTimeNotIncreasing,
                                kSessionNotOpen, kNoSession };

struct JobRecord {
  int64_t id = 0;
  std::string type, state, params_json, message;
  double progress = 0;
  std::optional<std::string> result_json;
  bool cancel_requested = false;
  int64_t attempts = 0, created_ms = 0;
  std::optional<int64_t> started_ms, finished_ms;
};

struct TileStateRecord {
  TileId tile;
  Bytes aggregate;               // encoded TileAggregate
  std::set<int64_t> sessions;    // sessions aggregated into the tile (their octrees = observed)
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

// A rectangle of tile indices, inclusive: tiles with min_x <= ix <= max_x and
// min_y <= iy <= max_y (the service converts metric boxes with TileGrid::TileOf).
struct Rect {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
};

class Storage {
 public:
  virtual ~Storage() = default;

  // --- tokens
  virtual void InsertToken(const TokenRecord& token, const std::string& hash) = 0;
  virtual std::optional<TokenRecord> FindActiveTokenByHash(const std::string& hash) = 0;
  virtual bool RevokeToken(const std::string& id, int64_t now_ms) = 0;
  virtual std::vector<TokenRecord> ListTokens() = 0;

  // --- prior map
  // Creates a new version with these tiles. If replace_all, tiles of the previous version
  // that are absent get an empty row so they read as empty at the new version.
  virtual int64_t CreatePriorVersion(const PriorVersionRecord& meta,
                                     const std::vector<PriorTileRecord>& tiles,
                                     bool replace_all) = 0;
  virtual std::optional<int64_t> LatestPriorVersion() = 0;
  virtual std::vector<PriorVersionRecord> ListPriorVersions() = 0;
  virtual std::optional<PriorTileRecord> GetPriorTile(const TileId& tile, int64_t version) = 0;
  // Tiles (without points) in the rect at a version, non-empty only.
  virtual std::vector<PriorTileRecord> ListPriorTiles(const Rect& rect, int64_t version) = 0;

  // --- sessions and keyframes
  virtual int64_t CreateSession(const SessionRecord& session) = 0;
  virtual std::optional<SessionRecord> GetSession(int64_t id) = 0;
  virtual PutKeyframeOutcome PutKeyframe(int64_t session_id, const KeyframeRecord& keyframe) = 0;
  // Keyframes with first_seq <= seq < end_seq in seq order, one at a time (a session's depth
  // images may not fit in memory). with_depth = false leaves depth_png empty (a commit's first
  // pass reads only the stored clouds). Safe to call from several threads at once.
  virtual void ForEachKeyframe(int64_t session_id, int64_t first_seq, int64_t end_seq,
                               bool with_depth,
                               const std::function<void(const KeyframeRecord&)>& fn) = 0;
  // Moves an open session to 'committing' and queues its commit job, atomically.
  // Returns the job id, or nullopt if the session is not open.
  virtual std::optional<int64_t> CommitSession(int64_t session_id, const std::string& params_json,
                                               int64_t now_ms) = 0;
  // Sets the session's state; "committed" also drops the keyframes' upload-time clouds.
  virtual void FinishSession(int64_t session_id, const std::string& state,
                             const std::optional<std::string>& registration_json,
                             int64_t now_ms) = 0;
  virtual void PutSessionObserved(int64_t session_id, const Bytes& observed) = 0;
  virtual std::optional<Bytes> GetSessionObserved(int64_t session_id) = 0;

  // --- jobs
  virtual int64_t CreateJob(const std::string& type, const std::string& params_json,
                            int64_t now_ms) = 0;
  virtual std::optional<JobRecord> GetJob(int64_t id) = 0;
  virtual std::vector<JobRecord> ListJobs(int64_t limit, int64_t offset) = 0;
  // Claims the oldest queued job (queued -> running, attempts+1).
  virtual std::optional<JobRecord> ClaimNextJob(int64_t now_ms) = 0;
  virtual void UpdateJobProgress(int64_t id, double progress, const std::string& message) = 0;
  virtual void FinishJob(int64_t id, const std::string& state, const std::string& message,
                         const std::optional<std::string>& result_json, int64_t now_ms) = 0;
  // Queued jobs are cancelled at once; running ones get cancel_requested. Returns new state.
  virtual std::optional<std::string> RequestCancel(int64_t id, int64_t now_ms) = 0;
  virtual bool IsCancelRequested(int64_t id) = 0;
  // At start-up: jobs left 'running' by a crash go back to 'queued' (to resume).
  virtual int RequeueInterruptedJobs() = 0;
  virtual std::set<std::string> JobTilesDone(int64_t job_id) = 0;
  virtual std::vector<std::pair<std::string, int64_t>> CountJobsByState() = 0;

  // --- per-tile aggregation and classification
  virtual std::optional<TileStateRecord> GetTileState(const TileId& tile) = 0;
  virtual std::vector<TileId> ListAggregatedTiles(const std::optional<Rect>& rect) = 0;
  // One transaction for all: each tile's state (aggregate + its session set) and
  // job_tiles(job, tile) (a commit applies its whole session at once: never half a session).
  virtual void ApplyTileUpdates(int64_t job_id, const std::vector<TileStateRecord>& states,
                                int64_t now_ms) = 0;
  // One transaction for all: the tiles' classifications, plus job_tiles(job, tile) if job_id > 0.
  virtual void ApplyTileChanges(int64_t job_id, const std::vector<TileChangesRecord>& changes) = 0;
  virtual std::optional<TileChangesRecord> GetTileChanges(const TileId& tile) = 0;
  // Tiles with max_confidence >= min_confidence and at least one change; total count too.
  virtual std::vector<TileChangesRecord> ListChangedTiles(const Rect& rect, double min_confidence,
                                                          int64_t limit, int64_t offset,
                                                          int64_t* total) = 0;
  // One transaction: new prior version (its job_id = job_id) with these tiles, their
  // aggregation and changes reset, a refresh_log row per tile, and result_json stored on the
  // job (which stays running: the caller finishes it after reclassifying the neighbours).
  virtual int64_t ApplyRefresh(int64_t job_id, const PriorVersionRecord& meta,
                               const std::vector<RefreshTileWrite>& tiles,
                               const std::string& result_json, int64_t now_ms) = 0;

  // --- settings (current classification parameters)
  virtual std::optional<std::string> GetSetting(const std::string& key) = 0;
  virtual void PutSetting(const std::string& key, const std::string& value) = 0;
};

// Opens (creating) the SQLite database and applies pending migrations in one transaction.
// Throws Error(kUnsupported) if the database's schema is newer than this build knows.
std::unique_ptr<Storage> OpenSqliteStorage(const std::string& path);
// Highest migration this build knows.
int KnownSchemaVersion();

}  // namespace mapdelta::server

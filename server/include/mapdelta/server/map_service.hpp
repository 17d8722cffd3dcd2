#pragma once
// MapService: the server's facade. Knows nothing of HTTP: takes parsed JSON and bytes, returns
// JSON or file bytes, throws ApiError (mapped to a status by the one error table). Tests call
// it directly; the HTTP adapter only parses requests and formats responses.
#include <nlohmann/json.hpp>

#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "mapdelta/common/precise_cloud.hpp"
#include "mapdelta/server/api_error.hpp"
#include "mapdelta/server/config.hpp"
#include "mapdelta/server/map_frame.hpp"
#include "mapdelta/server/metrics.hpp"
#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

using Json = nlohmann::json;

class ObservedTileCache;

struct FilePayload {
  Bytes bytes;
  std::string content_type;
  int64_t prior_version = 0;
  std::string etag;        // names the content (empty: none); the HTTP adapter answers 304 on it
  bool immutable = false;  // the same URL always answers these bytes (a prior tile at a version)
};

int64_t NowMs();

class MapService {
 public:
  MapService(ServerConfig config, std::unique_ptr<Storage> storage);
  ~MapService();  // stops the job worker
  MapService(const MapService&) = delete;
  MapService& operator=(const MapService&) = delete;

  const ServerConfig& config() const { return config_; }
  Storage& storage() { return *storage_; }
  Metrics& metrics() { return metrics_; }

  // Throws kUnauthenticated (no/unknown token) or kForbidden (role not allowed).
  TokenRecord Authorize(std::string_view authorization_header, std::initializer_list<Role> allowed);

  // --- vehicle
  Json CreateSession(const Json& body);
  // created is true for a new keyframe, false for an identical retry.
  Json PutKeyframe(int64_t session_id, int64_t seq, const Json& meta, const Bytes& depth_png,
                   bool* created);
  Json CommitSession(int64_t session_id);
  Json GetSession(int64_t session_id);

  // --- the map's frame (map_frame.hpp): user coordinates = local + origin
  // The stored frame; a map without one (before any import, or from before frames) is at
  // origin 0 without a CRS.
  MapFrame Frame();
  // GET /v1/map: CRS, origin, extent of the latest prior (user coordinates), version.
  Json GetMap();

  // --- prior map
  // Points in user coordinates; the first import sets the map's frame (see map_frame.hpp),
  // later ones must agree with it. Refuses, storing nothing, a cloud with a point farther than
  // kMaxLocalCoordinateM from the origin (float32 would round it by more than 0.25 mm).
  Json ImportPrior(const Bytes& cloud_bytes, const std::string& format, const std::string& note,
                   const FrameRequest& frame = {});
  Json ImportPriorFile(const std::string& path, const std::string& note,
                       const FrameRequest& frame = {});
  Json ListPriorTilesNear(double x, double y, double radius_m, std::optional<int64_t> version);
  FilePayload GetPriorTile(const std::string& tile, std::optional<int64_t> version,
                           const std::string& format);
  Json ListPriorVersions();

  // --- changes
  // min_support > 0 filters point by point (both thresholds on the same point) and reports
  // the counts of the points that pass; 0 uses the stored per-tile summary (no decoding).
  Json ListChangedTiles(const std::string& bbox, double min_confidence, int64_t page,
                        int64_t page_size, int64_t min_support = 0);
  // format json -> JSON text; pcd/ply -> cloud of one kind (kind required). cluster_states
  // (comma-separated, e.g. "confirmed,applied"): only the points of the tile's change clusters
  // in those states, and in JSON each point's cluster_id.
  FilePayload GetTileChanges(const std::string& tile, const std::string& format,
                             const std::string& kind, double min_confidence, int64_t min_support,
                             const std::optional<std::string>& cluster_states = std::nullopt);
  // The tile's observed area: the merge of its sessions' octrees cropped to the tile (.bt), from
  // the ObservedTileCache when that tile state was served before. Its ETag names the stored tile
  // state; client_has(etag) true (the request's If-None-Match) returns the payload without
  // bytes and without merging (the adapter answers 304).
  FilePayload GetObservedTile(const std::string& tile,
                              const std::function<bool(const std::string&)>& client_has = {});
  ObservedCacheStats ObservedCacheStatistics() const;

  // --- change clusters and their feed (issue #20; change_cluster_store.hpp, change_lifecycle.hpp)
  // Clusters whose state changed after the position `since` (a previous answer's "next"; absent
  // = from the start), in order, at most `limit` (default 100, at most 1000). The parameters are
  // the query's text; bad ones throw kInvalidArgument naming them.
  Json ChangeFeed(const std::optional<std::string>& since, const std::optional<std::string>& limit);
  // Clusters in a bbox (user coordinates; absent = all) and state (absent = any), by id.
  Json ListClusters(const std::optional<std::string>& bbox, const std::optional<std::string>& state,
                    int64_t page, int64_t page_size);
  Json GetCluster(int64_t cluster_id);  // with its transitions; kNotFound if unknown
  // An admin's decision, body {"cause": "..."}: confirmed (from candidate or rejected) or
  // rejected (from candidate or confirmed); kClusterState otherwise.
  Json DecideCluster(int64_t cluster_id, ClusterState to, const Json& body,
                     const std::string& admin_name);

  // --- coverage and freshness (issue #20 item 4; coverage_store.hpp)
  // Every tile with prior points in the bbox (user coordinates), by (ix, iy): how many of its
  // points sessions created in the last `days` days (1..3650) observed, the newest observation
  // (any age), and those sessions and vehicles. kNoPrior without a prior map.
  Json ListCoverageTiles(const std::string& bbox, int64_t days, int64_t page, int64_t page_size);
  // One tile's, with the sessions of the window; kNotFound if it has no prior points.
  Json GetTileCoverage(const std::string& tile, int64_t days);

  // --- admin jobs
  Json CreateJob(const Json& body);
  Json ListJobs(int64_t page, int64_t page_size);
  Json GetJob(int64_t job_id);
  Json CancelJob(int64_t job_id);

  Json Health();
  std::string RenderMetrics();

  // Background job worker. Start() resumes jobs a crash left running. Stop() asks the running
  // job to stop between tiles (it resumes at the next start) and joins.
  void StartJobWorker();
  void StopJobWorker();
  // For tests and the import CLI: runs queued jobs in this thread until none is left.
  void RunQueuedJobsNow();
  bool stopping() const { return stopping_; }

 private:
  void WorkerLoop();
  bool RunOneJob();
  int64_t RequirePriorVersion();
  // An uploaded pose (user coordinates) in the local frame; ApiError(kInvalidArgument) if its
  // position is beyond kMaxLocalCoordinateM of the origin.
  SE3 LocalPose(const SE3& T_map_cam_user);
  MapFrame ResolveImportFrame(const FrameRequest& request, const PrecisePointCloud& user_points,
                              bool* chosen);

  ServerConfig config_;
  std::unique_ptr<Storage> storage_;
  Metrics metrics_;
  std::atomic<bool> stopping_{false};
  std::thread worker_;
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::mutex frame_mutex_;
  std::optional<MapFrame> frame_;  // cached once stored: a map's frame never changes
  std::unique_ptr<ObservedTileCache> observed_cache_;  // http.observed_cache_bytes
};

}  // namespace mapdelta::server

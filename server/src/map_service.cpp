// MapService: authorization, upload sessions, the job worker, health and metrics.
// Queries and admin endpoints are in map_service_queries.cpp.
#include "mapdelta/server/map_service.hpp"

#include <algorithm>
#include <chrono>

#include "api_json.hpp"
#include "auth.hpp"
#include "blob_codec.hpp"
#include "change_lifecycle.hpp"
#include "heap_trim.hpp"
#include "job_lease.hpp"
#include "jobs.hpp"
#include "keyframe_cloud.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "observed_tile_cache.hpp"
#include "tile_work.hpp"

namespace mapdelta::server {

namespace {

// Reads a PNG's IHDR (the first chunk, by the PNG spec) and checks it against the session
// camera before anything is decoded: a small upload may claim a huge image (a decompression
// bomb); the decoder would allocate it first and complain later.
void CheckPngHeader(const Bytes& png, const PinholeCamera& camera) {
  static constexpr uint8_t kMagic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static constexpr uint8_t kIhdr[8] = {0, 0, 0, 13, 'I', 'H', 'D', 'R'};
  if (png.size() < 33 || !std::equal(kMagic, kMagic + 8, png.begin()) ||
      !std::equal(kIhdr, kIhdr + 8, png.begin() + 8)) {
    throw ApiError(ApiCode::kInvalidImage,
                   "part 'depth': not a PNG (bad signature or no IHDR chunk)");
  }
  auto be32 = [&](size_t at) {
    return (uint32_t{png[at]} << 24) | (uint32_t{png[at + 1]} << 16) |
           (uint32_t{png[at + 2]} << 8) | png[at + 3];
  };
  const uint32_t width = be32(16), height = be32(20);
  if (width != static_cast<uint32_t>(camera.width) ||
      height != static_cast<uint32_t>(camera.height)) {
    throw ApiError(ApiCode::kImageSizeMismatch,
                   "part 'depth': image is " + std::to_string(width) + "x" +
                       std::to_string(height) + ", session camera is " +
                       std::to_string(camera.width) + "x" + std::to_string(camera.height));
  }
  if (png[24] != 16 || png[25] != 0) {
    throw ApiError(ApiCode::kInvalidImage,
                   "part 'depth': must be a 16-bit grayscale PNG (bit depth " +
                       std::to_string(png[24]) + ", colour type " + std::to_string(png[25]) + ")");
  }
}

}  // namespace

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

MapService::MapService(ServerConfig config, std::unique_ptr<Storage> storage)
    : config_(std::move(config)), storage_(std::move(storage)) {
  ValidateServerConfig(config_);
  // Every publish of tile changes from here on keeps the change clusters' lifecycle.
  storage_->tiles().SetClusterLifecycle(std::make_shared<ChangeLifecycle>(config_.lifecycle));
  observed_cache_ = std::make_unique<ObservedTileCache>(config_.http.observed_cache_bytes);
}

MapService::~MapService() { StopJobWorker(); }

TokenRecord MapService::Authorize(std::string_view header, std::initializer_list<Role> allowed) {
  if (header.empty())
    throw ApiError(ApiCode::kUnauthenticated, "missing 'Authorization: Bearer <token>' header");
  auto token = Authenticate(*storage_, header);
  if (!token) throw ApiError(ApiCode::kUnauthenticated, "unknown, malformed or revoked token");
  if (!RoleAllows(token->role, allowed)) {
    std::string roles;
    for (Role r : allowed) roles += (roles.empty() ? "" : " or ") + std::string(ToString(r));
    throw ApiError(ApiCode::kForbidden, "role '" + std::string(ToString(token->role)) +
                                            "' may not do this (needs " + roles + " or admin)");
  }
  return *token;
}

// ---------------------------------------------------------------- sessions

Json MapService::CreateSession(const Json& body) {
  RejectUnknownFields(body, {"vehicle_id", "camera", "depth_scale"}, "body");
  const std::string vehicle = StringField(body, "vehicle_id");
  if (vehicle.empty() || vehicle.size() > 128) {
    throw ApiError(ApiCode::kInvalidArgument, "field 'vehicle_id': must have 1..128 characters");
  }
  const PinholeCamera camera = CameraFromJson(Field(body, "camera"), config_.ingest);
  double depth_scale = kDefaultDepthScale;
  if (body.contains("depth_scale")) depth_scale = NumberField(body, "depth_scale");
  if (!(depth_scale >= 1.0 && depth_scale <= 100000.0)) {
    throw ApiError(ApiCode::kInvalidArgument,
                   "field 'depth_scale': must be in [1, 100000] units per metre");
  }
  SessionRecord r;
  r.vehicle_id = vehicle;
  r.camera_json = CameraToJson(camera).dump();
  r.depth_scale = depth_scale;
  r.created_ms = NowMs();
  const int64_t id = storage_->sessions().Create(r);
  MD_LOG(kInfo, "session " << id << " created for vehicle '" << vehicle << "'");
  return GetSession(id);
}

Json MapService::PutKeyframe(int64_t session_id, int64_t seq, const Json& meta,
                             const Bytes& depth_png, bool* created) {
  const auto session = storage_->sessions().Get(session_id);
  if (!session)
    throw ApiError(ApiCode::kNotFound, "session " + std::to_string(session_id) + " does not exist");
  // Validate everything before touching storage: nothing is stored half-way.
  try {
    if (seq < 0) throw ApiError(ApiCode::kInvalidArgument, "seq must be >= 0");
    if (seq >= config_.ingest.max_keyframes_per_session) {
      throw ApiError(ApiCode::kLimitExceeded,
                     "seq " + std::to_string(seq) + " exceeds ingest.max_keyframes_per_session");
    }
    RejectUnknownFields(meta, {"t_ns", "T_map_cam", "covariance"}, "meta");
    const int64_t t_ns = IntField(meta, "t_ns");
    if (t_ns < 0) throw ApiError(ApiCode::kInvalidArgument, "field 't_ns': must be >= 0");
    const SE3 T = LocalPose(PoseFromJson(Field(meta, "T_map_cam"), "T_map_cam"));
    std::optional<Matrix6d> cov;
    if (meta.contains("covariance")) cov = CovarianceFromJson(meta["covariance"], "covariance");
    const PinholeCamera camera = CameraFromJson(Json::parse(session->camera_json), config_.ingest);
    CheckPngHeader(depth_png, camera);
    DepthImage depth;
    try {
      depth = DecodeDepthPng(std::vector<unsigned char>(depth_png.begin(), depth_png.end()),
                             session->depth_scale);
    } catch (const std::exception& e) {
      throw ApiError(ApiCode::kInvalidImage, std::string("part 'depth': ") + e.what());
    }
    if (depth.width != camera.width || depth.height != camera.height) {
      throw ApiError(ApiCode::kImageSizeMismatch,
                     "part 'depth': image is " + std::to_string(depth.width) + "x" +
                         std::to_string(depth.height) + ", session camera is " +
                         std::to_string(camera.width) + "x" + std::to_string(camera.height));
    }
    KeyframeRecord k;
    k.seq = seq;
    k.t_ns = t_ns;
    k.pose_json = PoseToJson(T).dump();
    if (cov) {
      Json c = Json::array();
      for (int i = 0; i < 36; ++i) c.push_back((*cov)(i / 6, i % 6));
      k.covariance_json = c.dump();
    }
    k.depth_png = depth_png;
    // The commit's first pass reads this instead of decoding the PNG a second time.
    k.cloud = EncodePoints(KeyframeCloud(camera, T, depth, config_.pipeline));
    k.cloud_params = KeyframeCloudParams(config_.pipeline);
    // Content identity of a retry: the canonical meta plus the PNG bytes.
    k.content_sha = Sha256Hex(std::to_string(t_ns) + "|" + k.pose_json + "|" +
                              k.covariance_json.value_or("null") + "|" +
                              std::string(depth_png.begin(), depth_png.end()));
    switch (storage_->sessions().PutKeyframe(session_id, k)) {
      case PutKeyframeOutcome::kStored:
        *created = true;
        metrics_.keyframes_ingested += 1;
        metrics_.keyframe_bytes += static_cast<int64_t>(depth_png.size());
        break;
      case PutKeyframeOutcome::kIdentical:
        *created = false;
        break;
      case PutKeyframeOutcome::kConflict:
        throw ApiError(
            ApiCode::kKeyframeConflict,
            "keyframe " + std::to_string(seq) + " was already uploaded with different content");
      case PutKeyframeOutcome::kOutOfOrder:
        throw ApiError(ApiCode::kSeqOutOfOrder,
                       "seq " + std::to_string(seq) + " is not the next one (expected " +
                           std::to_string(storage_->sessions().Get(session_id)->keyframe_count) +
                           ")");
      case PutKeyframeOutcome::kTimeNotIncreasing:
        throw ApiError(ApiCode::kTimeNotIncreasing,
                       "t_ns must be greater than the previous keyframe's");
      case PutKeyframeOutcome::kSessionNotOpen:
        throw ApiError(ApiCode::kSessionNotOpen,
                       "session is " + std::string(ToString(session->state)) + ", not open");
      case PutKeyframeOutcome::kNoSession:
        throw ApiError(ApiCode::kNotFound, "session does not exist");
    }
    return Json{{"session_id", session_id}, {"seq", seq}, {"stored", *created}};
  } catch (const ApiError& e) {
    metrics_.keyframes_rejected += 1;
    throw;
  }
}

Json MapService::CommitSession(int64_t session_id) {
  const auto session = storage_->sessions().Get(session_id);
  if (!session)
    throw ApiError(ApiCode::kNotFound, "session " + std::to_string(session_id) + " does not exist");
  if (session->keyframe_count == 0) {
    throw ApiError(ApiCode::kInvalidArgument, "session has no keyframes to commit");
  }
  const auto job =
      storage_->sessions().Commit(session_id, Json{{"session_id", session_id}}.dump(), NowMs());
  if (!job) {
    throw ApiError(ApiCode::kSessionNotOpen,
                   "session is " + std::string(ToString(session->state)) + ", not open");
  }
  wake_.notify_all();
  MD_LOG(kInfo, "session " << session_id << " committed: job " << *job);
  return Json{
      {"session_id", session_id}, {"job_id", *job}, {"state", ToString(SessionState::kCommitting)}};
}

Json MapService::GetSession(int64_t session_id) {
  const auto s = storage_->sessions().Get(session_id);
  if (!s)
    throw ApiError(ApiCode::kNotFound, "session " + std::to_string(session_id) + " does not exist");
  Json j{{"session_id", s->id},
         {"vehicle_id", s->vehicle_id},
         {"camera", Json::parse(s->camera_json)},
         {"depth_scale", s->depth_scale},
         {"state", ToString(s->state)},
         {"keyframe_count", s->keyframe_count},
         {"next_seq", s->keyframe_count},
         {"created_at", IsoTime(s->created_ms)}};
  if (s->committed_ms) j["committed_at"] = IsoTime(*s->committed_ms);
  if (s->job_id) {
    j["job_id"] = *s->job_id;
    if (auto job = storage_->jobs().Get(*s->job_id)) {
      j["job"] = {
          {"state", ToString(job->state)}, {"progress", job->progress}, {"message", job->message}};
    }
  }
  if (s->registration_json) j["registration"] = Json::parse(*s->registration_json);
  if (s->localization_json) j["localization"] = Json::parse(*s->localization_json);
  return j;
}

// ---------------------------------------------------------------- health, metrics

Json MapService::Health() {
  Json j{{"status", "ok"}, {"schema_version", KnownSchemaVersion()}};
  j["prior_version"] = storage_->priors().LatestVersion().value_or(0);
  for (const auto& [state, n] : storage_->jobs().CountByState()) {
    j["jobs"][std::string(ToString(state))] = n;
  }
  return j;
}

std::string MapService::RenderMetrics() {
  return metrics_.Render(storage_->jobs().CountByState(), observed_cache_->Stats());
}

// ---------------------------------------------------------------- job worker

void MapService::StartJobWorker() {
  const int requeued = storage_->jobs().RequeueInterrupted(NowMs());
  if (requeued > 0) MD_LOG(kWarn, requeued << " job(s) interrupted by a previous stop will resume");
  stopping_ = false;
  worker_ = std::thread([this] { WorkerLoop(); });
}

void MapService::StopJobWorker() {
  stopping_ = true;
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void MapService::WorkerLoop() {
  while (!stopping_) {
    bool ran = false;
    try {
      ran = RunOneJob();
      // No job to start: help classify the tiles of commits other workers run.
      if (!ran)
        ran = ClassifyClaimedTiles(*storage_, config_, std::nullopt,
                                   [this] { return stopping_.load(); }) > 0;
    } catch (const std::exception& e) {
      MD_LOG(kError, "job worker: " << e.what());
    }
    // A job's transient memory (decoded session octrees, clouds) is freed by now; without this
    // malloc keeps it and RSS grows with every commit (heap_trim.hpp).
    if (ran) ReturnFreedHeapToSystem();
    if (!ran) {
      std::unique_lock lock(wake_mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(250));
    }
  }
}

void MapService::RunQueuedJobsNow() {
  while (RunOneJob()) {
  }
}

bool MapService::RunOneJob() {
  const int64_t lease_ms = int64_t{config_.jobs.lease_s} * 1000;
  JobStore& jobs = storage_->jobs();
  auto job = jobs.ClaimNext(NowMs(), lease_ms);
  if (!job) return false;
  const auto t0 = std::chrono::steady_clock::now();
  MD_LOG(kInfo, "job " << job->id << " (" << ToString(job->type) << ") started, attempt "
                       << job->attempts << ", worker " << jobs.worker_id());
  const LeaseKeeper lease(jobs, job->id, lease_ms);
  JobContext ctx{*storage_, config_, metrics_, *job,
                 [&] { return stopping_.load() || lease.lost(); }};
  std::optional<int64_t> session_id;
  if (job->type == JobType::kCommit) {
    session_id = Json::parse(job->params_json).value("session_id", int64_t{0});
  }
  try {
    Json result;
    switch (job->type) {
      case JobType::kCommit:
        result = RunCommitJob(ctx);
        break;
      case JobType::kRefresh:
        result = RunRefreshJob(ctx);
        break;
      case JobType::kReclassify:
        result = RunReclassifyJob(ctx);
        break;
      case JobType::kRollback:
        result = RunRollbackJob(ctx);
        break;
    }
    jobs.Finish(job->id, JobState::kSucceeded, "done", result.dump(), NowMs());
    MD_LOG(kInfo, "job " << job->id << " succeeded: " << result.dump());
  } catch (const JobYield& e) {
    MD_LOG(kInfo, "job " << job->id << " back to the queue: " << e.what());
    jobs.Release(job->id);
    return true;  // claim again: the earlier job comes first
  } catch (const JobInterrupted& e) {
    if (lease.lost()) return true;  // its new worker finishes it
    if (!e.cancelled) {
      MD_LOG(kInfo, "job " << job->id
                           << " paused by shutdown; another worker or the next start resumes it");
      jobs.Release(job->id);
      return false;
    }
    jobs.Finish(job->id, JobState::kCancelled, "cancelled while running (finished tiles kept)",
                std::nullopt, NowMs());
    if (session_id)
      storage_->sessions().Finish(*session_id, SessionState::kFailed, std::nullopt, NowMs());
    MD_LOG(kInfo, "job " << job->id << " cancelled");
  } catch (const std::exception& e) {
    if (lease.lost()) {
      MD_LOG(kWarn, "job " << job->id << " stopped after its lease was lost: " << e.what());
      return true;
    }
    jobs.Finish(job->id, JobState::kFailed, e.what(), std::nullopt, NowMs());
    if (session_id)
      storage_->sessions().Finish(*session_id, SessionState::kFailed, std::nullopt, NowMs());
    MD_LOG(kError, "job " << job->id << " failed: " << e.what());
  }
  metrics_.jobs_finished += 1;
  metrics_.job_seconds_ms +=
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - t0)
          .count();
  return true;
}

}  // namespace mapdelta::server

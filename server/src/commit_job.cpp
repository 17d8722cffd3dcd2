// The commit job: a session's keyframes become per-tile aggregated evidence and new changes.
//   1. session cloud: back-project depth < th_d (every pixel_stride-th pixel), voxel filter
//   2. GICP-align it to the prior (paper step 2); a rejected alignment keeps the poses
//   3. the session's observed octree (hits < th_d, free rays of th_f, bounded by
//      free_ray_bound_px, under pipeline.free_space's rule), with the corrected poses
//   4. per touched tile, one transaction: add the session's voxels (support) and membership
//   5. coverage: per touched tile, which prior points the session observed (coverage.hpp)
//   6. reclassify touched tiles and their neighbours (paper Alg. 1 + 2 on the aggregate)
// Steps 1 and 3 run in parallel over chunks of keyframes (commit_passes.cpp); step 1 reads the
// clouds stored at upload, so each depth PNG is decoded once per commit. Step 4 writes in one
// transaction; step 6's tiles are work items any worker may classify (tile_work.hpp), their
// results published in one transaction. A cancel request is honoured until step 4 starts; from then
// on the job completes (a shutdown still pauses it, and it resumes at the next start).
#include <chrono>

#include "api_json.hpp"
#include "blob_codec.hpp"
#include "commit_passes.hpp"
#include "coverage.hpp"
#include "jobs.hpp"
#include "localization_quality.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/registration_gate.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "tile_classifier.hpp"
#include "tile_work.hpp"

namespace mapdelta::server {
namespace {

VoxelKey KeyOf(const Point& p, double voxel_m) {
  return {static_cast<int32_t>(std::floor(p.x() / voxel_m)),
          static_cast<int32_t>(std::floor(p.y() / voxel_m)),
          static_cast<int32_t>(std::floor(p.z() / voxel_m))};
}

// One tile's part of the session cloud, with each point's keyframe support.
struct TilePoints {
  PointCloud points;
  std::vector<uint32_t> keyframes;
};

std::map<TileId, TilePoints> SplitByTile(const TileGrid& grid, const PointCloud& cloud,
                                         const std::vector<uint32_t>& keyframes) {
  std::map<TileId, TilePoints> out;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud[i].allFinite()) continue;  // as TileGrid::Split
    TilePoints& tile = out[grid.TileOf(cloud[i])];
    tile.points.push_back(cloud[i]);
    tile.keyframes.push_back(keyframes[i]);
  }
  return out;
}

// Adds one session's points (already voxel-filtered) to a tile's aggregate. A voxel keeps the
// most keyframes any one session put in it (when two of the session's points meet in one voxel,
// after the correction or at a voxel boundary, the better supported one: adding would count
// keyframes twice).
void AddToAggregate(TileAggregate* agg, const TilePoints& tile, int64_t session_id,
                    double voxel_m) {
  for (size_t i = 0; i < tile.points.size(); ++i) {
    const Point& p = tile.points[i];
    AggregateVoxel& v = (*agg)[KeyOf(p, voxel_m)];
    v.centroid = (v.centroid * static_cast<float>(v.point_count) + p) /
                 static_cast<float>(v.point_count + 1);
    v.point_count += 1;
    v.keyframes = std::max(v.keyframes, tile.keyframes[i]);
    if (std::find(v.sessions.begin(), v.sessions.end(), session_id) == v.sessions.end()) {
      v.sessions.insert(std::upper_bound(v.sessions.begin(), v.sessions.end(), session_id),
                        session_id);
    }
  }
}

struct Registration {
  SE3 T_correction = SE3::Identity();
  Json report;
};

// Step 2: align the session cloud to the prior tiles it overlaps.
Registration AlignToPrior(JobContext& ctx, const TileGrid& grid, const PointCloud& session_cloud,
                          std::optional<int64_t> prior_version) {
  Registration r;
  const PipelineConfig& p = ctx.config.pipeline;
  if (!p.gicp_enabled) {
    r.report = {{"status", "skipped"}, {"reason", "pipeline.gicp_enabled is false"}};
    return r;
  }
  if (!prior_version || session_cloud.size() < 50) {
    r.report = {{"status", "skipped"},
                {"reason", prior_version ? "too few session points" : "no prior map"}};
    return r;
  }
  const AxisAlignedBox b = Bounds(session_cloud);
  PointCloud prior;
  for (const TileId& t :
       grid.TilesInRect(b.min.x() - 5, b.min.y() - 5, b.max.x() + 5, b.max.y() + 5)) {
    if (auto tile = ctx.storage.priors().GetTile(t, *prior_version)) {
      const PointCloud pts = DecodePoints(tile->points);
      prior.insert(prior.end(), pts.begin(), pts.end());
    }
  }
  if (prior.size() < 50) {
    r.report = {{"status", "skipped"}, {"reason", "too few prior points under the session"}};
    return r;
  }
  prior = VoxelDownsample(prior, static_cast<float>(p.session_voxel_m));
  GicpParams gp;
  gp.max_correspondence_m = p.gicp_max_correspondence_m;
  gp.num_threads = p.threads;
  const RegistrationResult result = AlignGicp(prior, session_cloud, SE3::Identity(), gp);
  RegistrationGate gate;
  gate.max_fitness_m = p.gicp_max_fitness_m;
  gate.max_correction_m = p.gicp_max_correction_m;
  const GateDecision decision = CheckRegistration(result, SE3::Identity(), gate);
  r.report = {{"status", decision.accepted ? "accepted" : "rejected"},
              {"reason", decision.reason},
              {"converged", result.converged},
              {"fitness_m", result.fitness_m},
              {"iterations", result.iterations},
              {"correction_m", decision.correction_m},
              {"correction_rad", decision.correction_rad},
              {"T_prior_session", PoseToJson(result.T_target_source)}};
  if (decision.accepted)
    r.T_correction = result.T_target_source;
  else
    MD_LOG(kWarn, "job " << ctx.job.id << ": GICP to prior rejected (" << decision.reason
                         << "); keeping the uploaded poses");
  return r;
}

// Step 4's tiles: where the session has points, or where it observed some prior point.
std::map<TileId, TilePoints> TouchedTiles(JobContext& ctx, const TileGrid& grid,
                                          const PointCloud& cloud,
                                          const std::vector<uint32_t>& keyframes,
                                          std::optional<int64_t> prior_version,
                                          const SessionObserved& session_observed) {
  std::map<TileId, TilePoints> by_tile = SplitByTile(grid, cloud, keyframes);
  const std::vector<Eigen::Vector3d>& camera_centres = session_observed.camera_centres;
  if (!prior_version || camera_centres.empty()) return by_tile;
  PointCloud centres;
  for (const auto& c : camera_centres) centres.push_back(c.cast<float>());
  const AxisAlignedBox b = Bounds(centres);
  const double reach = ctx.config.pipeline.max_depth_m;
  for (const TileId& t : grid.TilesInRect(b.min.x() - reach, b.min.y() - reach, b.max.x() + reach,
                                          b.max.y() + reach)) {
    if (by_tile.count(t)) continue;
    auto prior = ctx.storage.priors().GetTile(t, *prior_version);
    if (!prior || prior->point_count == 0) continue;
    for (const Point& p : DecodePoints(prior->points)) {
      if (session_observed.area.IsObserved(p)) {
        by_tile[t];  // observed but without session points (e.g. a removed building)
        break;
      }
    }
  }
  return by_tile;
}

// The largest position standard deviation of every keyframe that uploaded a covariance.
std::vector<double> UploadedPositionSigmas(Storage& storage, const SessionRecord& session) {
  std::vector<double> out;
  storage.sessions().ForEachKeyframe(session.id, 0, session.keyframe_count, false,
                                     [&](const KeyframeRecord& k) {
                                       if (!k.covariance_json) return;
                                       if (auto s = PositionSigma(*k.covariance_json))
                                         out.push_back(*s);
                                     });
  return out;
}

struct Classified {
  int64_t tiles = 0, new_points = 0, removed_points = 0;
  Json by = Json::object();  // worker id -> tiles it classified
};

// Step 6: the touched tiles and their aggregated neighbours as one work item each, classified
// by this and any other worker (tile_work.hpp), published at once.
Classified ClassifyTouchedTiles(JobContext& ctx, const std::map<TileId, TilePoints>& by_tile,
                                int64_t prior_version, int64_t session_id,
                                ObservedArea session_area) {
  std::set<TileId> to_classify_set;
  for (const auto& [tile, unused] : by_tile) {
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy)
        to_classify_set.insert(TileId(tile.ix() + dx, tile.iy() + dy));
    }
  }
  std::vector<TileId> to_classify;
  for (const TileId& t : to_classify_set) {
    if (ctx.storage.tiles().GetState(t)) to_classify.push_back(t);
  }
  ObservedCache cache(ctx.storage);
  cache.Put(session_id, std::move(session_area));
  Classified out;
  for (const TileWorkItem& item :
       ClassifyCommitTiles(ctx.storage, ctx.config, ctx.job.id, prior_version, to_classify,
                           ctx.shutting_down, cache)) {
    out.tiles += 1;
    out.new_points += item.new_count;
    out.removed_points += item.removed_count;
    const std::string worker = item.done_by.value_or("");
    out.by[worker] = out.by.value(worker, 0) + 1;
  }
  return out;
}

}  // namespace

Json RunCommitJob(JobContext& ctx) {
  const auto t0 = std::chrono::steady_clock::now();
  const Json params = Json::parse(ctx.job.params_json);
  const int64_t session_id = params.at("session_id").get<int64_t>();
  const auto session = ctx.storage.sessions().Get(session_id);
  if (!session)
    throw ApiError(ApiCode::kNotFound, "session " + std::to_string(session_id) + " is gone");
  const PinholeCamera camera = CameraFromJson(Json::parse(session->camera_json), ctx.config.ingest);
  const PipelineConfig& pc = ctx.config.pipeline;
  const TileGrid grid(ctx.config.storage.tile_size_m);

  // 1. Session cloud (from the clouds stored at upload).
  const SessionCloud session_cloud = BuildSessionCloud(ctx, *session, camera, 0.0, 0.2);
  PointCloud cloud = session_cloud.cloud;
  const auto t1 = std::chrono::steady_clock::now();

  // 2. Align to the prior (the one an earlier refresh job makes, as with a single worker).
  ctx.WaitForEarlierJobs(JobType::kRefresh);
  const std::optional<int64_t> prior_version = ctx.storage.priors().LatestVersion();
  const Registration reg = AlignToPrior(ctx, grid, cloud, prior_version);
  cloud = Transform(cloud, reg.T_correction);
  // How much this session's evidence counts, before any tile sees it (localization_quality.hpp).
  const LocalizationQuality quality =
      AssessLocalization(reg.report, UploadedPositionSigmas(ctx.storage, *session), pc);
  ctx.storage.sessions().PutLocalization(session_id, quality.weight, quality.ToJson().dump());
  ctx.CheckStop();
  const auto t2 = std::chrono::steady_clock::now();

  // 3. Observed octree with corrected poses (under pipeline.free_space's rule).
  SessionObserved session_observed =
      BuildSessionObserved(ctx, *session, camera, reg.T_correction, 0.2, 0.8);
  ctx.storage.sessions().PutObserved(session_id,
                                     EncodeObserved(session_observed.area.SerializeEvidence()));
  const auto t3 = std::chrono::steady_clock::now();

  // 4. Touched tiles: where the session has points, or observed some prior point.
  const std::map<TileId, TilePoints> by_tile = TouchedTiles(
      ctx, grid, cloud, session_cloud.keyframe_support, prior_version, session_observed);
  // Last point at which a cancel request stops the job: from here on it writes, after every
  // earlier job (tiles aggregate sessions in commit order, however many workers run).
  ctx.CheckStop();
  ctx.WaitForEarlierJobs();
  // All touched tiles in one transaction, so a crash leaves either none or all of them with
  // the session; on resume, any tile in job_tiles means the whole step is done.
  if (ctx.storage.jobs().TilesDone(ctx.job.id).empty()) {
    std::vector<TileStateRecord> states;
    for (const auto& [tile, points] : by_tile) {
      TileStateRecord state;
      state.tile = tile;
      TileAggregate agg;
      if (auto existing = ctx.storage.tiles().GetState(tile)) {
        state.sessions = existing->sessions;
        agg = DecodeAggregate(existing->aggregate);
      }
      if (!state.sessions.count(session_id)) {
        AddToAggregate(&agg, points, session_id, pc.session_voxel_m);
        state.sessions.insert(session_id);
      }
      state.aggregate = EncodeAggregate(agg);
      states.push_back(std::move(state));
    }
    ctx.CheckShutdown();
    ctx.storage.tiles().ApplyUpdates(ctx.job.id, states, NowMs());
    ctx.metrics.job_tiles_applied += static_cast<int64_t>(states.size());
  }
  ctx.Progress(0.85, "aggregated " + std::to_string(by_tile.size()) + " tiles");
  const auto t4 = std::chrono::steady_clock::now();

  // 5. Coverage of the touched tiles' prior points at the latest version (idempotent, so a
  // resumed job writes it again). Every tile where the session observed a prior point is a
  // touched tile.
  std::vector<TileId> touched;
  for (const auto& [tile, unused] : by_tile) touched.push_back(tile);
  const int64_t tiles_covered =
      WriteSessionCoverage(ctx.storage, *session, session_observed.area, touched);
  const auto t4c = std::chrono::steady_clock::now();

  // 6. Reclassify touched tiles and neighbours whose margin saw the new evidence.
  const Classified classified = ClassifyTouchedTiles(ctx, by_tile, prior_version.value_or(0),
                                                     session_id, std::move(session_observed.area));
  ctx.storage.sessions().Finish(session_id, SessionState::kCommitted, reg.report.dump(), NowMs());
  const auto t5 = std::chrono::steady_clock::now();
  auto secs = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  return Json{{"session_id", session_id},
              {"keyframes", session->keyframe_count},
              {"session_points", cloud.size()},
              {"tiles_aggregated", by_tile.size()},
              {"tiles_classified", classified.tiles},
              {"tiles_covered", tiles_covered},
              {"tiles_classified_by", classified.by},
              {"keyframe_clouds_recomputed", session_cloud.recomputed},
              {"new_points", classified.new_points},
              {"removed_points", classified.removed_points},
              {"prior_version", prior_version.value_or(0)},
              {"registration", reg.report},
              {"localization", quality.ToJson()},
              {"seconds",
               {{"session_cloud", secs(t0, t1)},
                {"registration", secs(t1, t2)},
                {"observed_area", secs(t2, t3)},
                {"aggregation", secs(t3, t4)},
                {"coverage", secs(t4, t4c)},
                {"classification", secs(t4c, t5)},
                {"total", secs(t0, t5)}}}};
}

}  // namespace mapdelta::server

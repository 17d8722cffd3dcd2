// The commit job: a session's keyframes become per-tile aggregated evidence and new changes.
//   1. session cloud: back-project depth < th_d (every pixel_stride-th pixel), voxel filter
//   2. GICP-align it to the prior (paper step 2); a rejected alignment keeps the poses
//   3. the session's observed octree (hits < th_d, free rays of th_f, bounded by
//      free_ray_bound_px), with the corrected poses
//   4. per touched tile, one transaction: add the session's voxels (support) and membership
//   5. reclassify touched tiles and their neighbours (paper Alg. 1 + 2 on the aggregate)
#include <chrono>
#include <thread>

#include "api_json.hpp"
#include "blob_codec.hpp"
#include "jobs.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/registration_gate.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "tile_classifier.hpp"

namespace mapdelta::server {
namespace {

struct DecodedKeyframe {
  int64_t seq = 0;
  SE3 T_map_cam;
  DepthImage depth;
};

DecodedKeyframe Decode(const KeyframeRecord& k, double depth_scale) {
  DecodedKeyframe d;
  d.seq = k.seq;
  d.T_map_cam = PoseFromJson(Json::parse(k.pose_json), "pose");
  d.depth = DecodeDepthPng(k.depth_png, depth_scale);
  return d;
}

// Runs fn(keyframe, worker) over all keyframes, decoding in `threads` workers, in batches so
// that only a few depth images are in memory at once.
void ForEachDecoded(JobContext& ctx, int64_t session_id, double depth_scale, int threads,
                    int64_t total, double progress0, double progress1, const char* stage,
                    const std::function<void(const DecodedKeyframe&, int)>& fn) {
  std::vector<KeyframeRecord> batch;
  int64_t done = 0;
  auto flush = [&] {
    std::vector<std::thread> pool;
    std::exception_ptr error;
    std::mutex error_mutex;
    for (int w = 0; w < threads; ++w) {
      pool.emplace_back([&, w] {
        try {
          for (size_t i = w; i < batch.size(); i += threads) fn(Decode(batch[i], depth_scale), w);
        } catch (...) {
          std::lock_guard lock(error_mutex);
          error = std::current_exception();
        }
      });
    }
    for (auto& t : pool) t.join();
    if (error) std::rethrow_exception(error);
    done += static_cast<int64_t>(batch.size());
    batch.clear();
    ctx.CheckStop();
    ctx.Progress(progress0 + (progress1 - progress0) * done / std::max<int64_t>(1, total),
                 std::string(stage) + ": " + std::to_string(done) + "/" + std::to_string(total));
  };
  ctx.storage.ForEachKeyframe(session_id, [&](const KeyframeRecord& k) {
    batch.push_back(k);
    if (static_cast<int>(batch.size()) >= 8 * threads) flush();
  });
  if (!batch.empty()) flush();
}

PointCloud BackProject(const PinholeCamera& camera, const DecodedKeyframe& k, int stride,
                       double max_depth_m) {
  PointCloud points;
  for (int v = 0; v < k.depth.height; v += stride) {
    for (int u = 0; u < k.depth.width; u += stride) {
      const float z = k.depth.at(u, v);
      if (!(z > 0.f) || z >= max_depth_m) continue;
      points.push_back((k.T_map_cam * camera.BackProject(u, v, z)).cast<float>());
    }
  }
  return points;
}

VoxelKey KeyOf(const Point& p, double voxel_m) {
  return {static_cast<int32_t>(std::floor(p.x() / voxel_m)),
          static_cast<int32_t>(std::floor(p.y() / voxel_m)),
          static_cast<int32_t>(std::floor(p.z() / voxel_m))};
}

// Adds one session's points (already voxel-filtered) to a tile's aggregate.
void AddToAggregate(TileAggregate* agg, const PointCloud& points, int64_t session_id, double voxel_m) {
  for (const Point& p : points) {
    AggregateVoxel& v = (*agg)[KeyOf(p, voxel_m)];
    v.centroid = (v.centroid * static_cast<float>(v.point_count) + p) /
                 static_cast<float>(v.point_count + 1);
    v.point_count += 1;
    if (std::find(v.sessions.begin(), v.sessions.end(), session_id) == v.sessions.end()) {
      v.sessions.insert(std::upper_bound(v.sessions.begin(), v.sessions.end(), session_id), session_id);
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
    r.report = {{"status", "skipped"}, {"reason", prior_version ? "too few session points" : "no prior map"}};
    return r;
  }
  const AxisAlignedBox b = Bounds(session_cloud);
  PointCloud prior;
  for (const TileId& t : grid.TilesInRect(b.min.x() - 5, b.min.y() - 5, b.max.x() + 5, b.max.y() + 5)) {
    if (auto tile = ctx.storage.GetPriorTile(t, *prior_version)) {
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
  if (decision.accepted) r.T_correction = result.T_target_source;
  else MD_LOG(kWarn, "job " << ctx.job.id << ": GICP to prior rejected (" << decision.reason
                            << "); keeping the uploaded poses");
  return r;
}

}  // namespace

Json RunCommitJob(JobContext& ctx) {
  const auto t0 = std::chrono::steady_clock::now();
  const Json params = Json::parse(ctx.job.params_json);
  const int64_t session_id = params.at("session_id").get<int64_t>();
  const auto session = ctx.storage.GetSession(session_id);
  if (!session) throw ApiError(ApiCode::kNotFound, "session " + std::to_string(session_id) + " is gone");
  const PinholeCamera camera = CameraFromJson(Json::parse(session->camera_json), ctx.config.ingest);
  const PipelineConfig& pc = ctx.config.pipeline;
  const TileGrid grid(ctx.config.storage.tile_size_m);
  const int threads = pc.threads;

  // 1. Session cloud, per worker then merged.
  std::vector<PointCloud> partial(threads);
  ForEachDecoded(ctx, session_id, session->depth_scale, threads, session->keyframe_count, 0.0, 0.3,
                 "session cloud", [&](const DecodedKeyframe& k, int w) {
                   const PointCloud pts = VoxelDownsample(
                       BackProject(camera, k, pc.pixel_stride, pc.max_depth_m),
                       static_cast<float>(pc.session_voxel_m));
                   partial[w].insert(partial[w].end(), pts.begin(), pts.end());
                 });
  PointCloud cloud;
  for (const auto& p : partial) cloud.insert(cloud.end(), p.begin(), p.end());
  cloud = VoxelDownsample(cloud, static_cast<float>(pc.session_voxel_m));
  const auto t1 = std::chrono::steady_clock::now();

  // 2. Align to the prior.
  const std::optional<int64_t> prior_version = ctx.storage.LatestPriorVersion();
  const Registration reg = AlignToPrior(ctx, grid, cloud, prior_version);
  cloud = Transform(cloud, reg.T_correction);
  ctx.CheckStop();
  const auto t2 = std::chrono::steady_clock::now();

  // 3. Observed octree with corrected poses, one octree per worker, merged.
  ObservedAreaParams op;
  op.resolution_m = pc.octree_resolution_m;
  op.max_depth_m = pc.max_depth_m;
  op.free_ray_m = pc.free_space_depth_m;
  op.free_ray_bound_window_px = pc.free_ray_bound_px;
  op.prefilter_voxel_m = pc.octree_resolution_m;
  // Rays through every pixel_stride-th pixel: at 800x450 and a 0.8 m octree, neighbouring
  // rays fall into the same voxels for most of their length (4x fewer rays at stride 2).
  op.pixel_stride = pc.pixel_stride;
  std::vector<ObservedArea> areas(threads, ObservedArea(pc.octree_resolution_m));
  std::vector<Eigen::Vector3d> camera_centres;
  std::mutex centres_mutex;
  ForEachDecoded(ctx, session_id, session->depth_scale, threads, session->keyframe_count, 0.3, 0.7,
                 "observed area", [&](const DecodedKeyframe& k, int w) {
                   const SE3 T = reg.T_correction * k.T_map_cam;
                   areas[w].InsertKeyframe(camera, T, k.depth, op);
                   std::lock_guard lock(centres_mutex);
                   camera_centres.push_back(T.translation());
                 });
  for (int w = 1; w < threads; ++w) areas[0].Merge(areas[w]);
  const ObservedArea& observed = areas[0];
  const std::string observed_bytes = observed.SerializeBinary();
  ctx.storage.PutSessionObserved(session_id, Bytes(observed_bytes.begin(), observed_bytes.end()));
  const auto t3 = std::chrono::steady_clock::now();

  // 4. Touched tiles: where the session has points, or observed some prior point.
  std::map<TileId, PointCloud> by_tile = grid.Split(cloud);
  if (prior_version && !camera_centres.empty()) {
    PointCloud centres;
    for (const auto& c : camera_centres) centres.push_back(c.cast<float>());
    const AxisAlignedBox b = Bounds(centres);
    const double reach = pc.max_depth_m;
    for (const TileId& t : grid.TilesInRect(b.min.x() - reach, b.min.y() - reach,
                                            b.max.x() + reach, b.max.y() + reach)) {
      if (by_tile.count(t)) continue;
      auto prior = ctx.storage.GetPriorTile(t, *prior_version);
      if (!prior || prior->point_count == 0) continue;
      for (const Point& p : DecodePoints(prior->points)) {
        if (observed.IsObserved(p)) {
          by_tile[t];  // observed but without session points (e.g. a removed building)
          break;
        }
      }
    }
  }
  const std::set<std::string> done = ctx.storage.JobTilesDone(ctx.job.id);
  size_t index = 0;
  for (const auto& [tile, points] : by_tile) {
    ctx.CheckStop();
    ++index;
    if (done.count(tile.ToString())) continue;
    TileStateRecord state;
    state.tile = tile;
    TileAggregate agg;
    if (auto existing = ctx.storage.GetTileState(tile)) {
      state.sessions = existing->sessions;
      agg = DecodeAggregate(existing->aggregate);
    }
    if (!state.sessions.count(session_id)) {
      AddToAggregate(&agg, points, session_id, pc.session_voxel_m);
      state.sessions.insert(session_id);
    }
    state.aggregate = EncodeAggregate(agg);
    ctx.storage.ApplyTileUpdate(ctx.job.id, state, NowMs());
    ctx.metrics.job_tiles_applied += 1;
    ctx.Progress(0.7 + 0.15 * index / by_tile.size(),
                 "aggregated tile " + tile.ToString() + " (" + std::to_string(index) + "/" +
                     std::to_string(by_tile.size()) + ")");
  }
  const auto t4 = std::chrono::steady_clock::now();

  // 5. Reclassify touched tiles and neighbours whose margin saw the new evidence.
  std::set<TileId> to_classify;
  for (const auto& [tile, points] : by_tile) {
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) to_classify.insert(TileId(tile.ix() + dx, tile.iy() + dy));
    }
  }
  const ClassifyConfig cc = CurrentClassifyConfig(ctx.storage, ctx.config.classify);
  ObservedCache cache(ctx.storage);
  int64_t new_points = 0, removed_points = 0, classified = 0;
  for (const TileId& tile : to_classify) {
    ctx.CheckStop();
    if (!ctx.storage.GetTileState(tile)) continue;
    TileClassification c = ClassifyTile(ctx.storage, grid, tile, prior_version.value_or(0), cc,
                                        pc.octree_resolution_m, cache);
    c.record.updated_ms = NowMs();
    ctx.storage.ApplyTileChanges(0, c.record);
    new_points += c.record.new_count;
    removed_points += c.record.removed_count;
    ++classified;
  }
  ctx.storage.FinishSession(session_id, "committed", reg.report.dump(), NowMs());
  const auto t5 = std::chrono::steady_clock::now();
  auto secs = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  return Json{{"session_id", session_id},
              {"keyframes", session->keyframe_count},
              {"session_points", cloud.size()},
              {"tiles_aggregated", by_tile.size()},
              {"tiles_classified", classified},
              {"new_points", new_points},
              {"removed_points", removed_points},
              {"prior_version", prior_version.value_or(0)},
              {"registration", reg.report},
              {"seconds",
               {{"session_cloud", secs(t0, t1)},
                {"registration", secs(t1, t2)},
                {"observed_area", secs(t2, t3)},
                {"aggregation", secs(t3, t4)},
                {"classification", secs(t4, t5)},
                {"total", secs(t0, t5)}}}};
}

}  // namespace mapdelta::server

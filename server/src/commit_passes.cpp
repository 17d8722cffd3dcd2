#include "commit_passes.hpp"

#include <atomic>
#include <optional>

#include "api_json.hpp"
#include "blob_codec.hpp"
#include "keyframe_cloud.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/parallel.hpp"
#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta::server {
namespace {

int64_t NumChunks(const SessionRecord& s, int64_t chunk) {
  return (s.keyframe_count + chunk - 1) / chunk;
}

// Reports progress after each finished chunk (from any worker).
class ChunkProgress {
 public:
  ChunkProgress(JobContext& ctx, int64_t chunks, double p0, double p1, std::string stage)
      : ctx_(ctx), chunks_(chunks), p0_(p0), p1_(p1), stage_(std::move(stage)) {}
  void ChunkDone() {
    const int64_t done = ++done_;
    ctx_.Progress(p0_ + (p1_ - p0_) * done / std::max<int64_t>(1, chunks_),
                  stage_ + ": " + std::to_string(done) + "/" + std::to_string(chunks_) + " chunks");
  }

 private:
  JobContext& ctx_;
  int64_t chunks_;
  double p0_, p1_;
  std::string stage_;
  std::atomic<int64_t> done_{0};
};

}  // namespace

ChangeDetectionParams PipelineDetectionParams(const PipelineConfig& pc) {
  ChangeDetectionParams params;
  ObservedAreaParams& op = params.observed;
  op.resolution_m = pc.octree_resolution_m;
  op.max_depth_m = pc.max_depth_m;
  op.free_ray_m = pc.free_space_depth_m;
  op.free_ray_bound_window_px = pc.free_ray_bound_px;
  op.prefilter_voxel_m = pc.octree_resolution_m;
  // Rays through every pixel_stride-th pixel: at 800x450 and a 0.8 m octree, neighbouring
  // rays fall into the same voxels for most of their length (4x fewer rays at stride 2).
  op.pixel_stride = pc.pixel_stride;
  // The whole job's budget: loops inside a parallel loop (the tile loop, the keyframe chunks)
  // run on their caller's thread alone (common/parallel.hpp).
  params.threads = op.threads = pc.threads;
  ApplyFreeSpaceRule(pc.free_space, &params);
  if (pc.free_space == "confident") {
    params.mask_min_keyframes = pc.mask_min_keyframes;
    params.mask_weak_radius_m = pc.mask_weak_radius_m;
  }
  if (params.free_rays_stop_at_prior) {
    throw Error(ErrorCode::kInvalidArgument, "pipeline.free_space '" + pc.free_space +
                                                 "': stopping rays at the prior's surfaces is "
                                                 "not implemented in the commit job");
  }
  return params;
}

SessionCloud BuildSessionCloud(JobContext& ctx, const SessionRecord& session,
                               const PinholeCamera& camera, double progress0, double progress1) {
  const PipelineConfig& pc = ctx.config.pipeline;
  const std::string params = KeyframeCloudParams(pc);
  const int64_t chunk = pc.chunk_keyframes, chunks = NumChunks(session, chunk);
  const auto session_voxel = static_cast<float>(pc.session_voxel_m);
  std::vector<PointCloud> parts(chunks);
  std::atomic<int64_t> recomputed{0};
  ChunkProgress progress(ctx, chunks, progress0, progress1, "session cloud");
  ParallelFor(static_cast<size_t>(chunks), pc.threads, [&](int64_t c) {
    ctx.CheckStop();
    bool stale = false;
    ctx.storage.sessions().ForEachKeyframe(
        session.id, c * chunk, (c + 1) * chunk, /*with_depth=*/false, [&](const KeyframeRecord& k) {
          if (k.cloud.empty() || k.cloud_params != params) {
            stale = true;
            return;
          }
          const PointCloud pts = VoxelDownsample(DecodePoints(k.cloud), session_voxel);
          parts[c].insert(parts[c].end(), pts.begin(), pts.end());
        });
    if (!stale) return progress.ChunkDone();
    // Rare (keyframes stored before migration 002, or pipeline parameters changed since the
    // upload): redo the chunk in seq order, decoding the PNGs of the stale keyframes only.
    parts[c].clear();
    ctx.storage.sessions().ForEachKeyframe(
        session.id, c * chunk, (c + 1) * chunk, /*with_depth=*/true, [&](const KeyframeRecord& k) {
          PointCloud pts;
          if (k.cloud.empty() || k.cloud_params != params) {
            pts = KeyframeCloud(camera, PoseFromJson(Json::parse(k.pose_json), "pose"),
                                DecodeDepthPng(k.depth_png, session.depth_scale), pc);
            ++recomputed;
          } else {
            pts = DecodePoints(k.cloud);
          }
          pts = VoxelDownsample(pts, session_voxel);
          parts[c].insert(parts[c].end(), pts.begin(), pts.end());
        });
    progress.ChunkDone();
  });
  SessionCloud out;
  size_t total = 0;
  for (const auto& p : parts) total += p.size();
  PointCloud all;
  all.reserve(total);
  for (const auto& p : parts) all.insert(all.end(), p.begin(), p.end());
  out.cloud = VoxelDownsample(all, session_voxel, &out.keyframe_support);
  out.recomputed = recomputed;
  return out;
}

SessionObserved BuildSessionObserved(JobContext& ctx, const SessionRecord& session,
                                     const PinholeCamera& camera, const SE3& T_correction,
                                     double progress0, double progress1) {
  const PipelineConfig& pc = ctx.config.pipeline;
  const ObservedAreaParams op = PipelineDetectionParams(pc).observed;

  const int64_t chunk = pc.chunk_keyframes, chunks = NumChunks(session, chunk);
  std::vector<std::optional<ObservedArea>> areas(chunks);
  std::vector<std::optional<Eigen::Vector3d>> centres(session.keyframe_count);
  ChunkProgress progress(ctx, chunks, progress0, progress1, "observed area");
  ParallelFor(static_cast<size_t>(chunks), pc.threads, [&](int64_t c) {
    ctx.CheckStop();
    ObservedArea area(pc.octree_resolution_m);
    ctx.storage.sessions().ForEachKeyframe(
        session.id, c * chunk, (c + 1) * chunk, /*with_depth=*/true, [&](const KeyframeRecord& k) {
          const SE3 T = T_correction * PoseFromJson(Json::parse(k.pose_json), "pose");
          area.InsertKeyframe(camera, T, DecodeDepthPng(k.depth_png, session.depth_scale), op);
          if (k.seq >= 0 && k.seq < static_cast<int64_t>(centres.size()))
            centres[k.seq] = T.translation();
        });
    areas[c] = std::move(area);
    progress.ChunkDone();
  });
  // Pairwise merges in a fixed tree over chunk order: (0+1)+(2+3)... The known voxels (what
  // every query uses) are the union whatever the order; the fixed order also makes the
  // stored log-odds independent of the schedule.
  for (int64_t step = 1; step < chunks; step *= 2) {
    std::vector<int64_t> left;
    for (int64_t i = 0; i + step < chunks; i += 2 * step) left.push_back(i);
    ParallelFor(left.size(), pc.threads, [&](size_t j) {
      const int64_t i = left[j];
      areas[i]->Merge(*areas[i + step]);
      areas[i + step].reset();
    });
  }
  SessionObserved out{chunks > 0 ? std::move(*areas[0]) : ObservedArea(pc.octree_resolution_m), {}};
  for (const auto& c : centres) {
    if (c) out.camera_centres.push_back(*c);
  }
  return out;
}

}  // namespace mapdelta::server

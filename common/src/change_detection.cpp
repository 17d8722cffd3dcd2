#include "mapdelta/common/change_detection.hpp"

#include <cmath>
#include <mutex>
#include <optional>

#include "mapdelta/common/depth_cloud.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/parallel.hpp"
#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta {
namespace {

void CheckThreshold(double th_ch_m) {
  if (!(std::isfinite(th_ch_m) && th_ch_m > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "th_ch must be a positive distance");
  }
}

// Points per claim of the per-point loops: a k-d tree query costs ~0.1-5 us.
constexpr size_t kPointGrain = 2048;

// Keeps cloud[i] where keep[i]; order preserved.
PointCloud Select(const PointCloud& cloud, const std::vector<char>& keep) {
  PointCloud out;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (keep[i]) out.push_back(cloud[i]);
  }
  return out;
}

// keep[i] = distance from cloud[i] to `reference` >= th (Alg. 2's test). Parallel over points.
std::vector<char> FarFrom(const PointCloud& cloud, const NeighborIndex& reference, double th,
                          int threads) {
  std::vector<char> keep(cloud.size(), 0);
  const float radius = static_cast<float>(th);
  ParallelFor(
      cloud.size(), threads,
      [&](size_t i) { keep[i] = !reference.AnyWithin(cloud[i], radius, /*inclusive=*/false); },
      kPointGrain);
  return keep;
}

// The points whose own voxel `observed` has seen free in at least `keyframes` keyframes.
PointCloud SeenFree(const PointCloud& points, const ObservedArea& observed, int keyframes,
                    int threads) {
  std::vector<char> keep(points.size(), 0);
  ParallelFor(
      points.size(), threads,
      [&](size_t i) { keep[i] = observed.IsSeenFree(points[i], keyframes); }, kPointGrain);
  return Select(points, keep);
}

}  // namespace

PointCloud NotSeenFree(const PointCloud& points, const ObservedArea& observed, int threads) {
  std::vector<char> keep(points.size(), 0);
  ParallelFor(
      points.size(), threads, [&](size_t i) { keep[i] = !observed.IsSeenFree(points[i], 1); },
      kPointGrain);
  return Select(points, keep);
}

void ApplyFreeSpaceRule(const std::string& rule, ChangeDetectionParams* params) {
  if (rule == "paper") {
    params->observed.depth_sigma_per_m2 = 0.0;
    params->free_rays_stop_at_prior = false;
    params->removed_min_free_keyframes = 0;
    params->new_footprint_radius_m = 0.0;
    params->new_not_seen_free = false;
    params->removed_mask_radius_m = 0.0;
    params->mask_min_keyframes = 0;
    params->mask_weak_radius_m = 0.0;
  } else if (rule == "confident") {
    params->observed.depth_sigma_per_m2 = 0.5e-3;
    params->observed.depth_sigma_factor = 3.0;
    params->free_rays_stop_at_prior = false;
    params->removed_min_free_keyframes = 3;
    params->new_footprint_radius_m = 1.6;
    params->new_not_seen_free = true;
    params->removed_mask_radius_m = 1.6;
    params->mask_min_keyframes = 2;
    params->mask_weak_radius_m = 0.5;
  } else {
    throw Error(ErrorCode::kInvalidArgument,
                "free-space rule '" + rule + "': expected paper or confident");
  }
}

PointCloud ObservedPriorCloud(const PointCloud& prior, const PointCloud& global,
                              const ObservedArea& observed, double th_ch_m, int threads) {
  CheckThreshold(th_ch_m);
  const NeighborIndex global_index(global);
  std::vector<char> keep(prior.size(), 0);
  ParallelFor(
      prior.size(), threads,
      [&](size_t i) {
        // The octree look-up is cheaper than the k-d tree query: try it first.
        keep[i] = observed.IsObserved(prior[i]) ||
                  global_index.AnyWithin(prior[i], static_cast<float>(th_ch_m), /*inclusive=*/true);
      },
      kPointGrain);
  return Select(prior, keep);
}

namespace {

// in[i] = points[i] lies within radius_m (horizontally) of some point of `prior`.
std::vector<char> InPriorFootprint(const PointCloud& points, const PointCloud& prior,
                                   double radius_m, int threads) {
  // The prior flattened onto z = 0 and thinned to a quarter of the radius (a building's wall
  // becomes one column), so the test is one 2-D radius query per point.
  PointCloud flat;
  flat.reserve(prior.size());
  for (const Point& p : prior) flat.emplace_back(p.x(), p.y(), 0.f);
  flat = VoxelDownsample(flat, static_cast<float>(radius_m / 4));
  const NeighborIndex footprint(flat);
  std::vector<char> in(points.size(), 0);
  const auto radius = static_cast<float>(radius_m);
  ParallelFor(
      points.size(), threads,
      [&](size_t i) {
        in[i] = footprint.AnyWithin(Point(points[i].x(), points[i].y(), 0.f), radius);
      },
      kPointGrain);
  return in;
}

}  // namespace

PointCloud WithinPriorFootprint(const PointCloud& points, const PointCloud& prior, double radius_m,
                                int threads) {
  if (!(radius_m > 0) || points.empty()) return points;
  return Select(points, InPriorFootprint(points, prior, radius_m, threads));
}

std::vector<size_t> MaskingPoints(const PointCloud& global, const PointCloud& prior,
                                  double reobserve_radius_m, double footprint_radius_m, int threads,
                                  const MaskingSupport& support) {
  if (!(reobserve_radius_m > 0 && std::isfinite(reobserve_radius_m)) ||
      !(footprint_radius_m >= 0 && std::isfinite(footprint_radius_m)) ||
      !(support.weak_radius_m >= 0 && std::isfinite(support.weak_radius_m))) {
    throw Error(ErrorCode::kInvalidArgument,
                "masking points: the re-observation radius must be > 0, the footprint's and the "
                "weak support's >= 0");
  }
  if (support.keyframes && support.keyframes->size() != global.size()) {
    throw Error(ErrorCode::kInvalidArgument,
                "masking points: " + std::to_string(support.keyframes->size()) +
                    " support counts for " + std::to_string(global.size()) + " points");
  }
  const auto min_keyframes = static_cast<uint32_t>(std::max(support.min_keyframes, 0));
  const auto weak = [&](size_t i) {
    if (!support.keyframes) return false;
    const uint32_t keyframes = (*support.keyframes)[i];
    return keyframes != 0 && keyframes < min_keyframes;
  };
  std::vector<char> masks(global.size(), 1);
  if (prior.empty()) {
    for (size_t i = 0; i < global.size(); ++i) masks[i] = !weak(i);
  } else {
    const std::vector<char> in_footprint =
        footprint_radius_m > 0 ? InPriorFootprint(global, prior, footprint_radius_m, threads)
                               : std::vector<char>(global.size(), 1);
    const NeighborIndex prior_index(prior);
    const auto radius = static_cast<float>(reobserve_radius_m);
    const auto weak_radius = static_cast<float>(support.weak_radius_m);
    ParallelFor(
        global.size(), threads,
        [&](size_t i) {
          if (weak(i)) {
            masks[i] = weak_radius > 0 && prior_index.AnyWithin(global[i], weak_radius);
          } else {
            masks[i] = !in_footprint[i] || prior_index.AnyWithin(global[i], radius);
          }
        },
        kPointGrain);
  }
  std::vector<size_t> out;
  for (size_t i = 0; i < global.size(); ++i) {
    if (masks[i]) out.push_back(i);
  }
  return out;
}

Changes ClassifyChanges(const PointCloud& global, const PointCloud& observed_prior, double th_ch_m,
                        int threads, const PointCloud* masking) {
  CheckThreshold(th_ch_m);
  Changes changes;
  {
    const NeighborIndex prior_index(observed_prior);
    changes.new_points = Select(global, FarFrom(global, prior_index, th_ch_m, threads));
  }
  const NeighborIndex masking_index(masking ? *masking : global);
  changes.removed_points =
      Select(observed_prior, FarFrom(observed_prior, masking_index, th_ch_m, threads));
  return changes;
}

namespace {

// Depth of keyframe i: from memory, or read from the folder on demand (bounded memory).
using DepthSource = std::function<DepthImage(size_t index)>;

// `support` (optional): per returned point, the keyframes that put a point in its voxel (each
// keyframe's cloud is downsampled on the same grid first, so it adds at most one point there).
PointCloud BuildGlobalCloudFrom(const KeyframeFolder& keyframes, const DepthSource& depth_of,
                                double max_depth_m, double voxel_m, int threads,
                                const ProgressFunction& progress,
                                std::vector<uint32_t>* support = nullptr) {
  if (!(max_depth_m > 0) || !(voxel_m > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "global cloud: max depth and voxel size must be > 0");
  }
  const size_t n = keyframes.keyframes.size();
  std::vector<PointCloud> per_keyframe(n);
  std::mutex progress_mutex;
  size_t done = 0;
  ParallelFor(n, threads, [&](size_t k) {
    const PointCloud points =
        DepthToCloud(keyframes.camera, depth_of(k), keyframes.keyframes[k].T_map_cam, max_depth_m);
    per_keyframe[k] = VoxelDownsample(points, static_cast<float>(voxel_m));
    const std::lock_guard lock(progress_mutex);
    if (progress) progress("global cloud", static_cast<double>(++done) / n);
  });
  PointCloud all;
  for (const auto& points : per_keyframe) all.insert(all.end(), points.begin(), points.end());
  return VoxelDownsample(all, static_cast<float>(voxel_m), support);
}

ChangeDetectionResult DetectChangesFrom(const KeyframeFolder& keyframes,
                                        const DepthSource& depth_of, const PointCloud& prior,
                                        const ChangeDetectionParams& params,
                                        const AlignFunction& align,
                                        const ProgressFunction& progress) {
  CheckThreshold(params.th_ch_m);
  if (params.removed_min_free_keyframes < 0 || params.removed_min_free_keyframes > 4) {
    throw Error(ErrorCode::kInvalidArgument,
                "change detection: removed_min_free_keyframes must be 0-4");
  }
  if (!(params.new_footprint_radius_m >= 0 && std::isfinite(params.new_footprint_radius_m))) {
    throw Error(ErrorCode::kInvalidArgument,
                "change detection: new_footprint_radius_m must be a distance >= 0 (0 = off)");
  }
  if (params.mask_min_keyframes < 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "change detection: mask_min_keyframes must be >= 0 (0 = off)");
  }
  if (!(params.mask_weak_radius_m >= 0 && std::isfinite(params.mask_weak_radius_m))) {
    throw Error(ErrorCode::kInvalidArgument,
                "change detection: mask_weak_radius_m must be a distance >= 0 (0 = off)");
  }
  if (!(params.removed_mask_radius_m >= 0 && std::isfinite(params.removed_mask_radius_m))) {
    throw Error(ErrorCode::kInvalidArgument,
                "change detection: removed_mask_radius_m must be a distance >= 0 (0 = off)");
  }
  if (keyframes.keyframes.empty()) {
    throw Error(ErrorCode::kInvalidArgument, "change detection: no keyframes");
  }
  const auto report = [&](const char* stage, double fraction) {
    if (progress) progress(stage, fraction);
  };
  ChangeDetectionResult result;
  result.observed = ObservedArea(params.observed.resolution_m);
  // 1. Global cloud P_g (depth cut th_d) and the prior, both at cloud_voxel_m.
  report("global cloud", 0.0);
  result.global =
      BuildGlobalCloudFrom(keyframes, depth_of, params.observed.max_depth_m, params.cloud_voxel_m,
                           params.threads, progress, &result.global_support);
  result.prior = VoxelDownsample(prior, static_cast<float>(params.cloud_voxel_m));
  MD_LOG(kInfo, "change detection: global cloud " << result.global.size() << " points, prior "
                                                  << result.prior.size() << " points");
  // 2. Optional alignment of P_g to P_p; the keyframe poses move with it.
  if (align) {
    report("alignment", 0.0);
    result.T_prior_global = align(result.prior, result.global);
    if (!IsValidPose(result.T_prior_global, 1e-4)) {
      throw Error(ErrorCode::kInternal,
                  "change detection: alignment returned an invalid transform");
    }
    result.global = Transform(result.global, result.T_prior_global);
  }
  // 3. Observed area A_obs from every keyframe (aligned poses); optionally rays without depth
  //    end at the prior's surfaces (the full-resolution prior: its voxels have no holes).
  const std::optional<PriorSurfaces> surfaces =
      params.free_rays_stop_at_prior
          ? std::optional<PriorSurfaces>(std::in_place, prior, params.observed.resolution_m)
          : std::nullopt;
  ObservedAreaParams observed_params = params.observed;
  observed_params.threads = params.threads;
  const size_t n = keyframes.keyframes.size();
  for (size_t k = 0; k < n; ++k) {
    report("observed area", static_cast<double>(k) / n);
    result.observed.InsertKeyframe(keyframes.camera,
                                   result.T_prior_global * keyframes.keyframes[k].T_map_cam,
                                   depth_of(k), observed_params, surfaces ? &*surfaces : nullptr);
  }
  report("observed area", 1.0);
  // 4. Alg. 1 then Alg. 2, then optionally the per-point evidence of each removed point.
  report("classification", 0.0);
  result.observed_prior = ObservedPriorCloud(result.prior, result.global, result.observed,
                                             params.th_ch_m, params.threads);
  // Under the mask radius only some global points may mask a removal (MaskingPoints).
  std::optional<PointCloud> masking;
  if (params.removed_min_free_keyframes > 0 && params.removed_mask_radius_m > 0) {
    masking.emplace();
    const MaskingSupport support{&result.global_support, params.mask_min_keyframes,
                                 params.mask_weak_radius_m};
    for (size_t i : MaskingPoints(result.global, result.prior, params.removed_mask_radius_m,
                                  params.new_footprint_radius_m, params.threads, support)) {
      masking->push_back(result.global[i]);
    }
  }
  result.changes = ClassifyChanges(result.global, result.observed_prior, params.th_ch_m,
                                   params.threads, masking ? &*masking : nullptr);
  result.changes.new_points = WithinPriorFootprint(result.changes.new_points, result.prior,
                                                   params.new_footprint_radius_m, params.threads);
  if (params.new_not_seen_free) {
    result.changes.new_points =
        NotSeenFree(result.changes.new_points, result.observed, params.threads);
  }
  if (params.removed_min_free_keyframes > 0) {
    result.changes.removed_points = SeenFree(result.changes.removed_points, result.observed,
                                             params.removed_min_free_keyframes, params.threads);
  }
  report("classification", 1.0);
  MD_LOG(kInfo, "change detection: observed prior "
                    << result.observed_prior.size() << ", new " << result.changes.new_points.size()
                    << ", removed " << result.changes.removed_points.size());
  return result;
}

DepthSource InMemory(const KeyframeFolder& keyframes) {
  for (const Keyframe& keyframe : keyframes.keyframes) {
    if (keyframe.depth.width != keyframes.camera.width ||
        keyframe.depth.height != keyframes.camera.height) {
      throw Error(ErrorCode::kInvalidArgument,
                  "keyframe " + std::to_string(keyframe.t_ns) + ": depth image is " +
                      std::to_string(keyframe.depth.width) + "x" +
                      std::to_string(keyframe.depth.height) + ", camera is " +
                      std::to_string(keyframes.camera.width) + "x" +
                      std::to_string(keyframes.camera.height));
    }
  }
  return [&keyframes](size_t k) { return keyframes.keyframes[k].depth; };
}

}  // namespace

PointCloud BuildGlobalCloud(const KeyframeFolder& keyframes, double max_depth_m, double voxel_m,
                            int threads) {
  return BuildGlobalCloudFrom(keyframes, InMemory(keyframes), max_depth_m, voxel_m, threads,
                              nullptr);
}

ChangeDetectionResult DetectChanges(const KeyframeFolder& keyframes, const PointCloud& prior,
                                    const ChangeDetectionParams& params, const AlignFunction& align,
                                    const ProgressFunction& progress) {
  return DetectChangesFrom(keyframes, InMemory(keyframes), prior, params, align, progress);
}

ChangeDetectionResult DetectChangesInFolder(const std::string& keyframe_dir,
                                            const PointCloud& prior,
                                            const ChangeDetectionParams& params,
                                            const AlignFunction& align,
                                            const ProgressFunction& progress) {
  const KeyframeFolder index = ReadKeyframeFolderIndex(keyframe_dir);
  const DepthSource from_disk = [&](size_t k) {
    return ReadKeyframeDepth(keyframe_dir, index, index.keyframes[k].t_ns);
  };
  return DetectChangesFrom(index, from_disk, prior, params, align, progress);
}

}  // namespace mapdelta

#include "mapdelta/common/change_detection.hpp"

#include <cmath>

#include "mapdelta/common/depth_cloud.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta {
namespace {

void CheckThreshold(double th_ch_m) {
  if (!(std::isfinite(th_ch_m) && th_ch_m > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "th_ch must be a positive distance");
  }
}

// Keeps cloud[i] where keep[i]; order preserved.
PointCloud Select(const PointCloud& cloud, const std::vector<char>& keep) {
  PointCloud out;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (keep[i]) out.push_back(cloud[i]);
  }
  return out;
}

// keep[i] = distance from cloud[i] to `reference` >= th (Alg. 2's test). Parallel over points.
std::vector<char> FarFrom(const PointCloud& cloud, const NeighborIndex& reference, double th) {
  std::vector<char> keep(cloud.size(), 0);
  const float radius = static_cast<float>(th);
#pragma omp parallel for schedule(dynamic, 2048)
  for (long i = 0; i < static_cast<long>(cloud.size()); ++i) {
    keep[i] = !reference.AnyWithin(cloud[i], radius, /*inclusive=*/false);
  }
  return keep;
}

}  // namespace

PointCloud ObservedPriorCloud(const PointCloud& prior, const PointCloud& global,
                              const ObservedArea& observed, double th_ch_m) {
  CheckThreshold(th_ch_m);
  const NeighborIndex global_index(global);
  std::vector<char> keep(prior.size(), 0);
#pragma omp parallel for schedule(dynamic, 2048)
  for (long i = 0; i < static_cast<long>(prior.size()); ++i) {
    // The octree look-up is cheaper than the k-d tree query: try it first.
    keep[i] = observed.IsObserved(prior[i]) ||
              global_index.AnyWithin(prior[i], static_cast<float>(th_ch_m), /*inclusive=*/true);
  }
  return Select(prior, keep);
}

Changes ClassifyChanges(const PointCloud& global, const PointCloud& observed_prior, double th_ch_m) {
  CheckThreshold(th_ch_m);
  Changes changes;
  {
    const NeighborIndex prior_index(observed_prior);
    changes.new_points = Select(global, FarFrom(global, prior_index, th_ch_m));
  }
  const NeighborIndex global_index(global);
  changes.removed_points =
      Select(observed_prior, FarFrom(observed_prior, global_index, th_ch_m));
  return changes;
}

PointCloud BuildGlobalCloud(const KeyframeFolder& keyframes, double max_depth_m, double voxel_m) {
  if (!(max_depth_m > 0) || !(voxel_m > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "global cloud: max depth and voxel size must be > 0");
  }
  const PinholeCamera& camera = keyframes.camera;
  for (const Keyframe& keyframe : keyframes.keyframes) {
    if (keyframe.depth.width != camera.width || keyframe.depth.height != camera.height) {
      throw Error(ErrorCode::kInvalidArgument,
                  "global cloud: depth image of keyframe " + std::to_string(keyframe.t_ns) +
                      " does not match the camera size");
    }
  }
  std::vector<PointCloud> per_keyframe(keyframes.keyframes.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (long k = 0; k < static_cast<long>(per_keyframe.size()); ++k) {
    const Keyframe& keyframe = keyframes.keyframes[k];
    const PointCloud points = DepthToCloud(camera, keyframe.depth, keyframe.T_map_cam, max_depth_m);
    per_keyframe[k] = VoxelDownsample(points, static_cast<float>(voxel_m));
  }
  PointCloud all;
  for (const auto& points : per_keyframe) all.insert(all.end(), points.begin(), points.end());
  return VoxelDownsample(all, static_cast<float>(voxel_m));
}

ChangeDetectionResult DetectChanges(const KeyframeFolder& keyframes, const PointCloud& prior,
                                    const ChangeDetectionParams& params, const AlignFunction& align,
                                    const ProgressFunction& progress) {
  CheckThreshold(params.th_ch_m);
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
  result.global = BuildGlobalCloud(keyframes, params.observed.max_depth_m, params.cloud_voxel_m);
  result.prior = VoxelDownsample(prior, static_cast<float>(params.cloud_voxel_m));
  MD_LOG(kInfo, "change detection: global cloud " << result.global.size() << " points, prior "
                                                  << result.prior.size() << " points");
  // 2. Optional alignment of P_g to P_p; the keyframe poses move with it.
  if (align) {
    report("alignment", 0.0);
    result.T_prior_global = align(result.prior, result.global);
    if (!IsValidPose(result.T_prior_global, 1e-4)) {
      throw Error(ErrorCode::kInternal, "change detection: alignment returned an invalid transform");
    }
    result.global = Transform(result.global, result.T_prior_global);
  }
  // 3. Observed area A_obs from every keyframe (aligned poses).
  const size_t n = keyframes.keyframes.size();
  for (size_t k = 0; k < n; ++k) {
    report("observed area", static_cast<double>(k) / n);
    const Keyframe& keyframe = keyframes.keyframes[k];
    result.observed.InsertKeyframe(keyframes.camera, result.T_prior_global * keyframe.T_map_cam,
                                   keyframe.depth, params.observed);
  }
  report("observed area", 1.0);
  // 4. Alg. 1 then Alg. 2.
  report("classification", 0.0);
  result.observed_prior = ObservedPriorCloud(result.prior, result.global, result.observed, params.th_ch_m);
  result.changes = ClassifyChanges(result.global, result.observed_prior, params.th_ch_m);
  report("classification", 1.0);
  MD_LOG(kInfo, "change detection: observed prior " << result.observed_prior.size() << ", new "
                                                    << result.changes.new_points.size() << ", removed "
                                                    << result.changes.removed_points.size());
  return result;
}

}  // namespace mapdelta

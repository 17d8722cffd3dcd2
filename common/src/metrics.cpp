#include "mapdelta/common/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/parallel.hpp"
#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta {
namespace {

// Number of points of `cloud` within th of `reference` (Alg. 3's calcNearestDist <= th_ch).
size_t CountWithin(const PointCloud& cloud, const PointCloud& reference, double th, int threads) {
  const NeighborIndex index(reference);
  std::vector<char> within(cloud.size(), 0);
  ParallelFor(
      cloud.size(), threads,
      [&](size_t i) { within[i] = index.AnyWithin(cloud[i], static_cast<float>(th)); }, 2048);
  return static_cast<size_t>(std::count(within.begin(), within.end(), 1));
}

double Ratio(size_t numerator, size_t denominator) {
  return denominator == 0 ? std::numeric_limits<double>::quiet_NaN()
                          : static_cast<double>(numerator) / static_cast<double>(denominator);
}

ChangeMetrics Evaluate(const MetricsInput& input, const MetricsParams& params,
                       bool reference_variant) {
  if (!(params.rho_p_m > 0) || !(params.th_ch_m > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "metrics: th_ch and rho_p must be > 0");
  }
  const float rho = static_cast<float>(params.rho_p_m);
  const double th = params.th_ch_m;
  // 1. Every cloud at rho_p.
  const PointCloud original = VoxelDownsample(input.original_scene, rho);
  const PointCloud changed = VoxelDownsample(input.changed_scene, rho);
  const PointCloud global = VoxelDownsample(input.global, rho);
  PointCloud detected_new = VoxelDownsample(input.detected_new, rho);
  PointCloud detected_removed = VoxelDownsample(input.detected_removed, rho);
  if (reference_variant) {
    detected_new = RadiusOutlierFilter(detected_new, params.outlier_radius_m,
                                       params.outlier_min_neighbors, params.threads);
    detected_removed = RadiusOutlierFilter(detected_removed, params.outlier_radius_m,
                                           params.outlier_min_neighbors, params.threads);
  }
  // 2. Ground truth: Alg. 2 with P_g := changed scene, P_p^obs := original scene.
  const Changes truth = ClassifyChanges(changed, original, th, params.threads);
  // 3. Its observed part: Alg. 1 with P_p := P_p,new / P_p,rm.
  const PointCloud new_observed =
      ObservedPriorCloud(truth.new_points, global, input.observed, th, params.threads);
  PointCloud removed_observed;
  if (reference_variant) {
    for (const Point& p : truth.removed_points) {
      if (input.observed.IsObserved(p)) removed_observed.push_back(p);
    }
  } else {
    removed_observed =
        ObservedPriorCloud(truth.removed_points, global, input.observed, th, params.threads);
  }
  // 4. Alg. 3 true positives and the four ratios.
  ChangeMetrics m;
  m.gt_new = truth.new_points.size();
  m.gt_removed = truth.removed_points.size();
  m.gt_new_observed = new_observed.size();
  m.gt_removed_observed = removed_observed.size();
  m.detected_new = detected_new.size();
  m.detected_removed = detected_removed.size();
  m.gt_removed_observed_tp = CountWithin(removed_observed, detected_removed, th, params.threads);
  m.gt_new_observed_tp = CountWithin(new_observed, detected_new, th, params.threads);
  m.detected_removed_tp = CountWithin(detected_removed, removed_observed, th, params.threads);
  m.detected_new_tp = CountWithin(detected_new, new_observed, th, params.threads);
  m.recall_new = Ratio(m.gt_new_observed_tp, m.gt_new_observed);
  m.precision_new = Ratio(m.detected_new_tp, m.detected_new);
  m.recall_removed = Ratio(m.gt_removed_observed_tp, m.gt_removed_observed);
  m.precision_removed = Ratio(m.detected_removed_tp, m.detected_removed);
  return m;
}

}  // namespace

PointCloud RadiusOutlierFilter(const PointCloud& cloud, double radius_m, int min_neighbors,
                               int threads) {
  if (!(radius_m > 0) || min_neighbors < 0) {
    throw Error(ErrorCode::kInvalidArgument, "outlier filter: radius must be > 0, neighbours >= 0");
  }
  const NeighborIndex index(cloud);
  std::vector<char> keep(cloud.size(), 0);
  ParallelFor(
      cloud.size(), threads,
      [&](size_t i) {
        // The search finds the point itself too.
        keep[i] = index.RadiusSearch(cloud[i], static_cast<float>(radius_m)).size() >=
                  static_cast<size_t>(min_neighbors) + 1;
      },
      1024);
  PointCloud out;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (keep[i]) out.push_back(cloud[i]);
  }
  return out;
}

ChangeMetrics EvaluateChangesPaper(const MetricsInput& input, const MetricsParams& params) {
  return Evaluate(input, params, false);
}

ChangeMetrics EvaluateChangesReferenceVariant(const MetricsInput& input,
                                              const MetricsParams& params) {
  return Evaluate(input, params, true);
}

}  // namespace mapdelta

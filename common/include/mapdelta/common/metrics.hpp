#pragma once
// Change-detection metrics of the paper (Lin et al., RA-L 2022, Sec. IV-B): recall and
// precision of the classes new and removed, R_new, P_new, R_rm, P_rm, computed on clouds
// downsampled to rho_p, with ground truth from Alg. 2 on the original vs changed scene clouds,
// its observed part from Alg. 1, and true positives from Alg. 3.
#include <cstddef>

#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

struct MetricsParams {
  double th_ch_m = 3.2;  // th_ch used for ground truth, observation and true positives
  double rho_p_m = 0.4;  // every cloud is voxel-downsampled to this first
  // Reference-evaluation variant only: radius outlier filter on the detected clouds
  // (a point is kept with at least min_neighbors other points within radius).
  double outlier_radius_m = 4.0;
  int outlier_min_neighbors = 16;
  int threads = 0;  // 0 = every hardware thread (parallel.hpp)
};

struct MetricsInput {
  const PointCloud& original_scene;    // ground-truth cloud of the scene the prior came from
  const PointCloud& changed_scene;     // ground-truth cloud of the scene the vehicles saw
  const PointCloud& detected_new;      // P_new
  const PointCloud& detected_removed;  // P_rm
  const PointCloud& global;            // P_g (Alg. 1 needs it for the observed ground truth)
  const ObservedArea& observed;        // A_obs
};

// Counts are point numbers after downsampling to rho_p. A ratio whose denominator is zero is NaN.
struct ChangeMetrics {
  double recall_new = 0, precision_new = 0, recall_removed = 0, precision_removed = 0;
  size_t gt_new = 0, gt_removed = 0;                    // N(P_p,new), N(P_p,rm)
  size_t gt_new_observed = 0, gt_removed_observed = 0;  // N(P_p,new^obs), N(P_p,rm^obs)
  size_t gt_new_observed_tp = 0, gt_removed_observed_tp = 0;
  size_t detected_new = 0, detected_removed = 0;  // N(P_new), N(P_rm) (after any filter)
  size_t detected_new_tp = 0, detected_removed_tp = 0;
};

// The paper's definition, exactly.
ChangeMetrics EvaluateChangesPaper(const MetricsInput& input, const MetricsParams& params = {});

// The variant of the paper's reference evaluation code: detected new/removed clouds pass a
// radius outlier filter first, and a ground-truth removed point counts as observed only when
// it lies in A_obs (not by its distance to P_g). Use it to compare with published numbers.
ChangeMetrics EvaluateChangesReferenceVariant(const MetricsInput& input,
                                              const MetricsParams& params = {});

// Radius outlier removal as PCL's RadiusOutlierRemoval (neighbours exclude the point itself).
PointCloud RadiusOutlierFilter(const PointCloud& cloud, double radius_m, int min_neighbors,
                               int threads);

}  // namespace mapdelta

#pragma once
// Where detected removed points come from (issue 21): every point of P_rm is labelled true or
// false as the paper's metric does (within th_ch of an observed ground-truth removed point),
// then explained by the keyframe rays through its pixel: how far, at what angle to the prior
// surface, whether the ray had a stereo depth beyond the point or no depth at all, whether the
// ground-truth depth says the point was hidden behind other geometry, whether the stereo depth
// overshot the ground truth, and (with a run at ground-truth poses) whether the point goes away
// when the poses are exact.
#include <optional>
#include <string>
#include <vector>

#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta::tools {

struct RemovedBreakdownInput {
  const PointCloud& original_scene;  // the prior's ground truth
  const PointCloud& changed_scene;
  const PointCloud& detected_removed;
  const PointCloud& global;
  const ObservedArea& observed;
  std::string keyframe_dir;  // the keyframes the detector used (poses + stereo depth)
  std::string gt_depth_dir;  // depth0/data of the sequence ("" = no depth attribution)
  const PointCloud* removed_at_gt_poses = nullptr;  // P_rm of the same depth at GT poses
};

struct RemovedBreakdownParams {
  double th_ch_m = 3.2;
  double rho_p_m = 0.4;          // the metric's downsampling (every cloud, as mapdelta-eval)
  double max_depth_m = 50.0;     // th_d: keyframe rays beyond it are not considered
  double free_ray_m = 20.0;      // th_f and the free-ray bound, as the detector ran: how far a
  int free_ray_bound_px = 128;   // pixel without depth is taken to see
  double same_point_m = 1.0;     // a GT-pose removed point this close means "not gone"
  double depth_margin_m = 1.0;   // "beyond the point", "hidden", "overshoot" need this margin
  double normal_radius_m = 1.2;  // neighbours of the original scene for the surface normal
  int threads = 0;               // 0 = every hardware thread (common/parallel.hpp)
};

// Mutually exclusive causes, checked in this order.
enum class RemovedCause {
  kPoseError,        // gone when the same depth is placed with ground-truth poses
  kNoDepthHidden,    // only no-depth rays pass it, and it is hidden behind other geometry
  kNoDepthVisible,   // only no-depth rays pass it; visible (ground truth) but not reconstructed
  kDepthOvershoot,   // a stereo depth beyond it, and that depth overshoots the ground truth
  kDepthBeyondTrue,  // a stereo depth beyond it that agrees with the ground truth (grazing)
  kNoCentreRay,      // no keyframe's ray through its own pixel passes it (voxel neighbour)
};
inline constexpr int kNumRemovedCauses = 6;
const char* RemovedCauseName(RemovedCause cause);

struct RemovedPointExplanation {
  Point p_map = Point::Zero();
  bool true_positive = false;
  int passing_depth = 0, passing_no_depth = 0;  // keyframes whose ray through its pixel passes it
  float range_m = -1.f;         // depth of the point in the nearest passing keyframe (-1: none)
  float view_angle_deg = -1.f;  // that ray against the surface normal (0 = head-on; -1: unknown)
  bool hidden = false;          // some passing ray's ground-truth depth ends before the point
  bool overshoot = false;       // some passing stereo depth exceeds its ground truth
  RemovedCause cause = RemovedCause::kNoCentreRay;
};

// Counts of false and true detected removed points (at rho_p) per bin of one attribute.
struct BreakdownTable {
  std::string attribute;
  std::vector<std::string> bins;
  std::vector<size_t> false_count, true_count;
};

struct RemovedBreakdown {
  size_t detected = 0, false_positives = 0;
  std::vector<RemovedPointExplanation> points;
  std::vector<BreakdownTable> tables;  // cause, range, view angle, hidden, overshoot
};

// Throws Error naming the file on unreadable keyframes or depth images.
RemovedBreakdown BreakDownRemoved(const RemovedBreakdownInput& input,
                                  const RemovedBreakdownParams& params);

}  // namespace mapdelta::tools

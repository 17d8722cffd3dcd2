#include "mapdelta/tools/removed_breakdown.hpp"

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>

#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/parallel.hpp"
#include "mapdelta/common/registration/gicp_factor.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "mapdelta/common/window_min.hpp"

namespace mapdelta::tools {
namespace {

constexpr float kUnknown = -1.f;

// Unit normal of the original scene's surface at p (PCA of the neighbours), or zero when too
// few neighbours make it meaningless.
Eigen::Vector3d SurfaceNormal(const PointCloud& scene, const NeighborIndex& index, const Point& p,
                              double radius_m) {
  const std::vector<size_t> near = index.RadiusSearch(p, static_cast<float>(radius_m));
  if (near.size() < 5) return Eigen::Vector3d::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i : near) mean += scene[i].cast<double>();
  mean /= static_cast<double>(near.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t i : near) {
    const Eigen::Vector3d d = scene[i].cast<double>() - mean;
    cov += d * d.transpose();
  }
  return PlaneNormal(cov / static_cast<double>(near.size())).normalized();
}

// The depth images of one keyframe: stereo (as the detector read it) and the ground truth of
// the same time, cropped like the keyframe camera (the client drops the unmatched left band).
struct KeyframeDepths {
  DepthImage stereo, truth;
  int truth_band = 0;          // columns the keyframe camera dropped on the left
  std::vector<float> nearest;  // the detector's free-ray bound: nearest depth within +-W px
};

KeyframeDepths LoadDepths(const RemovedBreakdownInput& input, const KeyframeFolder& index,
                          const Keyframe& keyframe, int bound_px) {
  KeyframeDepths out;
  out.stereo = ReadKeyframeDepth(input.keyframe_dir, index, keyframe.t_ns);
  if (bound_px > 0) out.nearest = NearestDepthAround(out.stereo, bound_px, 1);
  if (input.gt_depth_dir.empty()) return out;
  const std::string path = input.gt_depth_dir + "/" + std::to_string(keyframe.t_ns) + ".png";
  if (!std::filesystem::exists(path)) {
    throw Error(ErrorCode::kNotFound,
                path + ": no ground-truth depth for keyframe " + std::to_string(keyframe.t_ns));
  }
  out.truth = ReadDepthPng(path);
  out.truth_band = out.truth.width - out.stereo.width;
  if (out.truth_band < 0 || out.truth.height != out.stereo.height) {
    throw Error(ErrorCode::kInvalidArgument, path + ": " + std::to_string(out.truth.width) + "x" +
                                                 std::to_string(out.truth.height) +
                                                 " is smaller than the keyframe depth");
  }
  return out;
}

bool Valid(float d) { return std::isfinite(d) && d > 0.f; }

// What one keyframe's ray through the point's pixel says about the point.
void ExplainWithKeyframe(const PinholeCamera& camera, const SE3& T_map_cam,
                         const KeyframeDepths& depths, const Eigen::Vector3d& normal,
                         const RemovedBreakdownParams& params, RemovedPointExplanation* e) {
  const Eigen::Vector3d p_cam = T_map_cam.inverse() * e->p_map.cast<double>();
  const double z = p_cam.z();
  if (z < 0.1 || z > params.max_depth_m) return;
  const int u = static_cast<int>(std::lround(camera.fx * p_cam.x() / z + camera.cx));
  const int v = static_cast<int>(std::lround(camera.fy * p_cam.y() / z + camera.cy));
  if (u < 0 || v < 0 || u >= camera.width || v >= camera.height) return;
  const float d = depths.stereo.at(u, v);
  const float margin = static_cast<float>(params.depth_margin_m);
  bool passes = false;
  if (Valid(d)) {
    passes = d > z + margin;
    if (passes) ++e->passing_depth;
  } else {
    float reach = static_cast<float>(params.free_ray_m);
    if (!depths.nearest.empty())
      reach = std::min(reach, depths.nearest[static_cast<size_t>(v) * camera.width + u]);
    passes = reach > z;
    if (passes) ++e->passing_no_depth;
  }
  if (!passes) return;
  if (!depths.truth.depth_m.empty()) {
    const float g = depths.truth.at(u + depths.truth_band, v);
    if (Valid(g) && g < z - margin) e->hidden = true;
    if (Valid(d) && Valid(g) && d > g + margin) e->overshoot = true;
  }
  if (e->range_m < 0 || z < e->range_m) {
    e->range_m = static_cast<float>(z);
    if (normal.squaredNorm() > 0.5) {
      const Eigen::Vector3d ray = (e->p_map.cast<double>() - T_map_cam.translation()).normalized();
      e->view_angle_deg =
          static_cast<float>(std::acos(std::min(1.0, std::abs(ray.dot(normal)))) * 180.0 / M_PI);
    }
  }
}

RemovedCause CauseOf(const RemovedPointExplanation& e, bool gone_at_gt_poses) {
  if (gone_at_gt_poses) return RemovedCause::kPoseError;
  if (e.passing_depth == 0 && e.passing_no_depth > 0) {
    return e.hidden ? RemovedCause::kNoDepthHidden : RemovedCause::kNoDepthVisible;
  }
  if (e.passing_depth > 0)
    return e.overshoot ? RemovedCause::kDepthOvershoot : RemovedCause::kDepthBeyondTrue;
  return RemovedCause::kNoCentreRay;
}

BreakdownTable Table(const std::string& attribute, const std::vector<std::string>& bins,
                     const std::vector<RemovedPointExplanation>& points,
                     const std::function<size_t(const RemovedPointExplanation&)>& bin_of) {
  BreakdownTable t{attribute, bins, std::vector<size_t>(bins.size(), 0),
                   std::vector<size_t>(bins.size(), 0)};
  for (const auto& e : points) ++(e.true_positive ? t.true_count : t.false_count)[bin_of(e)];
  return t;
}

std::vector<BreakdownTable> Tables(const std::vector<RemovedPointExplanation>& points) {
  std::vector<std::string> causes;
  for (int c = 0; c < kNumRemovedCauses; ++c)
    causes.push_back(RemovedCauseName(static_cast<RemovedCause>(c)));
  const auto range_bin = [](const RemovedPointExplanation& e) -> size_t {
    if (e.range_m < 0) return 5;
    const float edges[] = {5.f, 10.f, 20.f, 30.f};
    size_t b = 0;
    while (b < 4 && e.range_m >= edges[b]) ++b;
    return b;
  };
  const auto angle_bin = [](const RemovedPointExplanation& e) -> size_t {
    if (e.view_angle_deg < 0) return 4;
    return e.view_angle_deg < 30 ? 0 : e.view_angle_deg < 60 ? 1 : e.view_angle_deg < 75 ? 2 : 3;
  };
  return {
      Table("cause", causes, points, [](const auto& e) { return static_cast<size_t>(e.cause); }),
      Table("range_m", {"0-5", "5-10", "10-20", "20-30", "30-50", "no ray"}, points, range_bin),
      Table("view_angle_deg", {"0-30", "30-60", "60-75", "75-90", "unknown"}, points, angle_bin),
      Table("hidden_behind_other_geometry", {"no", "yes"}, points,
            [](const auto& e) -> size_t { return e.hidden; }),
      Table("stereo_depth_overshoot", {"no", "yes"}, points,
            [](const auto& e) -> size_t { return e.overshoot; })};
}

}  // namespace

const char* RemovedCauseName(RemovedCause cause) {
  switch (cause) {
    case RemovedCause::kPoseError:
      return "pose error (gone at GT poses)";
    case RemovedCause::kNoDepthHidden:
      return "no-depth ray, point hidden";
    case RemovedCause::kNoDepthVisible:
      return "no-depth ray, point visible";
    case RemovedCause::kDepthOvershoot:
      return "depth beyond it, overshoot";
    case RemovedCause::kDepthBeyondTrue:
      return "depth beyond it, true depth";
    case RemovedCause::kNoCentreRay:
      return "no ray through its pixel";
  }
  return "?";
}

RemovedBreakdown BreakDownRemoved(const RemovedBreakdownInput& input,
                                  const RemovedBreakdownParams& params) {
  const float rho = static_cast<float>(params.rho_p_m);
  // 1. Labels exactly as the paper's metric: true when within th_ch of an observed GT removed
  // point.
  const PointCloud original = VoxelDownsample(input.original_scene, rho);
  const PointCloud changed = VoxelDownsample(input.changed_scene, rho);
  const PointCloud global = VoxelDownsample(input.global, rho);
  const PointCloud detected = VoxelDownsample(input.detected_removed, rho);
  const Changes truth = ClassifyChanges(changed, original, params.th_ch_m, params.threads);
  const PointCloud removed_observed = ObservedPriorCloud(
      truth.removed_points, global, input.observed, params.th_ch_m, params.threads);
  const NeighborIndex truth_index(removed_observed), original_index(original);
  std::optional<PointCloud> at_gt;
  if (input.removed_at_gt_poses) at_gt = VoxelDownsample(*input.removed_at_gt_poses, rho);
  const std::optional<NeighborIndex> at_gt_index =
      at_gt ? std::optional<NeighborIndex>(std::in_place, *at_gt) : std::nullopt;
  RemovedBreakdown out;
  out.detected = detected.size();
  out.points.resize(detected.size());
  std::vector<Eigen::Vector3d> normals(detected.size());
  ParallelFor(
      detected.size(), params.threads,
      [&](size_t i) {
        out.points[i].p_map = detected[i];
        out.points[i].true_positive =
            truth_index.AnyWithin(detected[i], static_cast<float>(params.th_ch_m));
        normals[i] = SurfaceNormal(original, original_index, detected[i], params.normal_radius_m);
      },
      256);
  // 2. Every keyframe's ray through each point's pixel (one keyframe in memory at a time).
  const KeyframeFolder index = ReadKeyframeFolderIndex(input.keyframe_dir);
  for (size_t k = 0; k < index.keyframes.size(); ++k) {
    const KeyframeDepths depths =
        LoadDepths(input, index, index.keyframes[k], params.free_ray_bound_px);
    ParallelFor(
        detected.size(), params.threads,
        [&](size_t i) {
          ExplainWithKeyframe(index.camera, index.keyframes[k].T_map_cam, depths, normals[i],
                              params, &out.points[i]);
        },
        1024);
    if ((k + 1) % 100 == 0)
      MD_LOG(kInfo,
             "removed breakdown: " << k + 1 << "/" << index.keyframes.size() << " keyframes");
  }
  // 3. Causes (a point the ground-truth-pose run no longer reports is the pose's doing).
  for (auto& e : out.points) {
    const bool gone =
        at_gt_index && !at_gt_index->AnyWithin(e.p_map, static_cast<float>(params.same_point_m));
    e.cause = CauseOf(e, gone);
    out.false_positives += e.true_positive ? 0 : 1;
  }
  out.tables = Tables(out.points);
  return out;
}

}  // namespace mapdelta::tools

#include "mapdelta/common/observed_area.hpp"

#include <cmath>
#include <vector>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "observed_area_impl.hpp"

namespace mapdelta {
namespace {

void CheckParams(const PinholeCamera& camera, const DepthImage& depth, const ObservedAreaParams& p) {
  camera.Validate();
  if (depth.width != camera.width || depth.height != camera.height ||
      depth.depth_m.size() != static_cast<size_t>(depth.width) * depth.height) {
    throw Error(ErrorCode::kInvalidArgument,
                "observed area: depth image is " + std::to_string(depth.width) + "x" +
                    std::to_string(depth.height) + ", camera is " + std::to_string(camera.width) +
                    "x" + std::to_string(camera.height));
  }
  const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(p.max_depth_m) || !positive(p.free_ray_m) || !positive(p.prefilter_voxel_m) ||
      p.pixel_stride < 1) {
    throw Error(ErrorCode::kInvalidArgument,
                "observed area: max_depth_m, free_ray_m, prefilter_voxel_m must be > 0 and "
                "pixel_stride >= 1");
  }
}

octomap::point3d ToOcto(const Point& p) { return {p.x(), p.y(), p.z()}; }

// Keys of the voxels each ray passes through (excluding its end voxel), in parallel: OctoMap's
// own OpenMP path does nothing in Debian's build (see DESIGN.md), and computeRayKeys is const.
octomap::KeySet RayKeys(const octomap::OcTree& tree, const octomap::point3d& origin,
                        const PointCloud& ends) {
  octomap::KeySet all;
#pragma omp parallel
  {
    octomap::KeySet local;
    octomap::KeyRay ray;
#pragma omp for schedule(dynamic, 64) nowait
    for (long i = 0; i < static_cast<long>(ends.size()); ++i) {
      if (tree.computeRayKeys(origin, ToOcto(ends[i]), ray)) local.insert(ray.begin(), ray.end());
    }
#pragma omp critical(mapdelta_observed_ray_keys)
    all.insert(local.begin(), local.end());
  }
  return all;
}

}  // namespace

ObservedArea::ObservedArea(double resolution_m) {
  if (!(std::isfinite(resolution_m) && resolution_m >= 1e-3)) {
    throw Error(ErrorCode::kInvalidArgument, "observed area: resolution must be >= 1 mm");
  }
  impl_ = std::make_unique<Impl>(resolution_m);
}
ObservedArea::~ObservedArea() = default;
ObservedArea::ObservedArea(const ObservedArea& other) : impl_(std::make_unique<Impl>(*other.impl_)) {}
ObservedArea& ObservedArea::operator=(const ObservedArea& other) {
  if (this != &other) impl_ = std::make_unique<Impl>(*other.impl_);
  return *this;
}
ObservedArea::ObservedArea(ObservedArea&&) noexcept = default;
ObservedArea& ObservedArea::operator=(ObservedArea&&) noexcept = default;

void ObservedArea::InsertKeyframe(const PinholeCamera& camera, const SE3& T_map_cam,
                                  const DepthImage& depth, const ObservedAreaParams& params) {
  CheckParams(camera, depth, params);
  if (!IsValidPose(T_map_cam, 1e-4)) {
    throw Error(ErrorCode::kInvalidArgument, "observed area: T_map_cam is not a valid rigid transform");
  }
  // 1. End points in the map frame: hits (valid depth below th_d) and free-ray ends (depth th_f).
  const Eigen::Isometry3f T = T_map_cam.cast<float>();
  PointCloud hits, free_ends;
  for (int v = 0; v < camera.height; v += params.pixel_stride) {
    for (int u = 0; u < camera.width; u += params.pixel_stride) {
      const float d = depth.at(u, v);
      const bool hit = std::isfinite(d) && d > 0.f && d < params.max_depth_m;
      const double z = hit ? d : params.free_ray_m;
      const Eigen::Vector3d p_cam = camera.BackProject(u, v, z);
      (hit ? hits : free_ends).push_back(T * p_cam.cast<float>());
    }
  }
  // 2. One end point per prefilter voxel: neighbouring pixels' rays cross the same voxels.
  hits = VoxelDownsample(hits, static_cast<float>(params.prefilter_voxel_m));
  free_ends = VoxelDownsample(free_ends, static_cast<float>(params.prefilter_voxel_m));

  // 3. Voxel keys: end voxels of hits are occupied; all other traversed voxels (and the end
  //    voxels of free rays) are free, unless some hit ended there (as OctoMap's discretized
  //    insertPointCloud does).
  auto& tree = impl_->tree;
  const octomap::point3d origin = ToOcto(T_map_cam.translation().cast<float>());
  octomap::KeySet occupied;
  for (const auto& p : hits) {
    octomap::OcTreeKey key;
    if (tree.coordToKeyChecked(ToOcto(p), key)) occupied.insert(key);
  }
  PointCloud all_ends = hits;
  all_ends.insert(all_ends.end(), free_ends.begin(), free_ends.end());
  octomap::KeySet free = RayKeys(tree, origin, all_ends);
  for (const auto& p : free_ends) {
    octomap::OcTreeKey key;
    if (tree.coordToKeyChecked(ToOcto(p), key)) free.insert(key);
  }
  // 4. Update (lazily, then the inner nodes once).
  for (const auto& key : free) {
    if (!occupied.count(key)) tree.updateNode(key, false, true);
  }
  for (const auto& key : occupied) tree.updateNode(key, true, true);
  tree.updateInnerOccupancy();
  tree.prune();
}

bool ObservedArea::IsObserved(const Point& p_map) const {
  if (!p_map.allFinite()) return false;
  return impl_->tree.search(ToOcto(p_map)) != nullptr;
}

void ObservedArea::Merge(const ObservedArea& other) {
  auto& tree = impl_->tree;
  const double res = tree.getResolution();
  if (std::abs(other.resolution_m() - res) > 1e-9) {
    throw Error(ErrorCode::kInvalidArgument, "observed area: cannot merge resolution " +
                                                 std::to_string(other.resolution_m()) + " into " +
                                                 std::to_string(res));
  }
  const unsigned max_depth = other.impl_->tree.getTreeDepth();
  for (auto it = other.impl_->tree.begin_leafs(), end = other.impl_->tree.end_leafs(); it != end; ++it) {
    const float log_odds = it->getLogOdds();
    if (it.getDepth() == max_depth) {
      tree.updateNode(it.getKey(), log_odds, true);
      continue;
    }
    // A pruned leaf stands for a cube of identical voxels: add each of them.
    const int n = 1 << (max_depth - it.getDepth());
    const octomap::point3d corner = it.getCoordinate() - octomap::point3d(1, 1, 1) * (it.getSize() / 2);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) {
          const octomap::point3d c = corner + octomap::point3d(i + 0.5f, j + 0.5f, k + 0.5f) * res;
          octomap::OcTreeKey key;
          if (tree.coordToKeyChecked(c, key)) tree.updateNode(key, log_odds, true);
        }
  }
  tree.updateInnerOccupancy();
}

size_t ObservedArea::NumKnownLeaves() const { return impl_->tree.getNumLeafNodes(); }
double ObservedArea::resolution_m() const { return impl_->tree.getResolution(); }

}  // namespace mapdelta

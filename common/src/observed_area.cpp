#include "mapdelta/common/observed_area.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/window_min.hpp"
#include "flat_key_set.hpp"
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
      p.pixel_stride < 1 || p.free_ray_bound_window_px < 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "observed area: max_depth_m, free_ray_m, prefilter_voxel_m must be > 0, "
                "pixel_stride >= 1 and free_ray_bound_window_px >= 0");
  }
}

octomap::point3d ToOcto(const Point& p) { return {p.x(), p.y(), p.z()}; }

// The end-point prefilter: one centroid per cubic voxel of edge `leaf`. Neighbouring pixels
// mostly land in the same voxel, so the last voxel is cached and the hash map is consulted
// only when the voxel changes (about 10x fewer look-ups than a plain voxel grid).
class EndPointFilter {
 public:
  explicit EndPointFilter(float leaf) : inv_leaf_(1.f / leaf), slot_of_key_(8192) {}
  void Add(const Point& p) {
    const Eigen::Vector3f scaled = (p * inv_leaf_).array().floor();
    if (!scaled.allFinite() || scaled.cwiseAbs().maxCoeff() >= (1 << 20)) return;
    const auto coord = [](float v) { return static_cast<uint64_t>(static_cast<int64_t>(v) + (1 << 20)); };
    const uint64_t key = (coord(scaled.x()) << 42) | (coord(scaled.y()) << 21) | coord(scaled.z());
    if (!has_last_ || key != last_key_) {
      const auto [slot, inserted] = slot_of_key_.Insert(key);
      if (inserted) {
        sums_.emplace_back(Eigen::Vector3d::Zero());
        counts_.push_back(0);
      }
      last_key_ = key;
      last_slot_ = slot;
      has_last_ = true;
    }
    sums_[last_slot_] += p.cast<double>();
    ++counts_[last_slot_];
  }
  PointCloud Centroids() const {
    PointCloud out(sums_.size());
    for (size_t i = 0; i < sums_.size(); ++i) out[i] = (sums_[i] / counts_[i]).cast<float>();
    return out;
  }

 private:
  float inv_leaf_;
  detail::FlatKeyIndex slot_of_key_;
  std::vector<Eigen::Vector3d> sums_;
  std::vector<uint32_t> counts_;
  bool has_last_ = false;
  uint64_t last_key_ = 0;
  size_t last_slot_ = 0;
};

// An OcTreeKey packed into one integer (48 bits), for the flat key sets below.
uint64_t Pack(const octomap::OcTreeKey& k) {
  return (static_cast<uint64_t>(k[0]) << 32) | (static_cast<uint64_t>(k[1]) << 16) | k[2];
}
octomap::OcTreeKey Unpack(uint64_t v) {
  return octomap::OcTreeKey(static_cast<octomap::key_type>(v >> 32), static_cast<octomap::key_type>((v >> 16) & 0xffff),
                            static_cast<octomap::key_type>(v & 0xffff));
}

// Keys of the voxels each ray passes through (excluding its end voxel), in parallel: OctoMap's
// own OpenMP path does nothing in Debian's build (see DESIGN.md), and computeRayKeys is const.
detail::FlatKeySet RayKeys(const octomap::OcTree& tree, const octomap::point3d& origin, const PointCloud& ends) {
  detail::FlatKeySet all(8 * ends.size());
#pragma omp parallel if (ends.size() > 4096)
  {
    detail::FlatKeySet local(4 * ends.size());
    octomap::KeyRay ray;
#pragma omp for schedule(dynamic, 64) nowait
    for (long i = 0; i < static_cast<long>(ends.size()); ++i) {
      if (!tree.computeRayKeys(origin, ToOcto(ends[i]), ray)) continue;
      for (const auto& key : ray) local.Insert(Pack(key));
    }
#pragma omp critical(mapdelta_observed_ray_keys)
    local.ForEach([&](uint64_t key) { all.Insert(key); });
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
  // 1-2. End points in the map frame, hits (valid depth below th_d) and free-ray ends (depth
  //      th_f), reduced on the fly to one centroid per prefilter voxel: neighbouring pixels'
  //      rays cross the same voxels.
  const Eigen::Isometry3f T = T_map_cam.cast<float>();
  const float inv_fx = static_cast<float>(1.0 / camera.fx), inv_fy = static_cast<float>(1.0 / camera.fy);
  const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  const float max_depth = static_cast<float>(params.max_depth_m);
  const float free_depth = static_cast<float>(params.free_ray_m);
  EndPointFilter hit_filter(static_cast<float>(params.prefilter_voxel_m));
  EndPointFilter free_filter(static_cast<float>(params.prefilter_voxel_m));
  const int stride = params.pixel_stride;
  const int nearest_cols = (camera.width + stride - 1) / stride;
  // The smallest valid depth within +-W pixels, read only at the strided pixels (window_min.hpp:
  // cv::erode with a 257x257 rectangle over the whole image was 26 % of a server commit's CPU).
  const std::vector<float> nearest = params.free_ray_bound_window_px > 0
                                         ? NearestDepthAround(depth, params.free_ray_bound_window_px, stride)
                                         : std::vector<float>();
  for (int v = 0; v < camera.height; v += stride) {
    const float y = (static_cast<float>(v) - cy) * inv_fy;
    for (int u = 0; u < camera.width; u += stride) {
      const float d = depth.at(u, v);
      const bool valid = std::isfinite(d) && d > 0.f;
      const bool hit = valid && d < max_depth;
      // A depth beyond th_d still says the space before it is free: never cast past it.
      // Without depth: th_f (paper), or with the bound no further than the nearest surface seen
      // around the pixel (nearest[] is +inf when the window holds no depth).
      const float no_depth = nearest.empty()
                                 ? free_depth
                                 : std::min(free_depth, nearest[static_cast<size_t>(v / stride) * nearest_cols + u / stride]);
      const float z = hit ? d : (valid ? std::min(d, free_depth) : no_depth);
      const Point p_map = T * Point((static_cast<float>(u) - cx) * inv_fx * z, y * z, z);
      (hit ? hit_filter : free_filter).Add(p_map);
    }
  }
  const PointCloud hits = hit_filter.Centroids();
  const PointCloud free_ends = free_filter.Centroids();

  // 3. Voxel keys: end voxels of hits are occupied; all other traversed voxels (and the end
  //    voxels of free rays) are free, unless some hit ended there (as OctoMap's discretized
  //    insertPointCloud does).
  auto& tree = impl_->tree;
  const octomap::point3d origin = ToOcto(T_map_cam.translation().cast<float>());
  detail::FlatKeySet occupied(hits.size());
  for (const auto& p : hits) {
    octomap::OcTreeKey key;
    if (tree.coordToKeyChecked(ToOcto(p), key)) occupied.Insert(Pack(key));
  }
  PointCloud all_ends = hits;
  all_ends.insert(all_ends.end(), free_ends.begin(), free_ends.end());
  detail::FlatKeySet free = RayKeys(tree, origin, all_ends);
  for (const auto& p : free_ends) {
    octomap::OcTreeKey key;
    if (tree.coordToKeyChecked(ToOcto(p), key)) free.Insert(Pack(key));
  }
  // 4. Update (lazily, then the inner nodes once). Each key is updated once per keyframe, so the
  //    order of the updates does not change the tree.
  free.ForEach([&](uint64_t key) {
    if (!occupied.Contains(key)) tree.updateNode(Unpack(key), false, true);
  });
  occupied.ForEach([&](uint64_t key) { tree.updateNode(Unpack(key), true, true); });
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

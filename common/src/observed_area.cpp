#include "mapdelta/common/observed_area.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <vector>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/parallel.hpp"
#include "mapdelta/common/window_min.hpp"
#include "observed_area_impl.hpp"

namespace mapdelta {
namespace {

void CheckParams(const PinholeCamera& camera, const DepthImage& depth,
                 const ObservedAreaParams& p) {
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
      p.pixel_stride < 1 || p.free_ray_bound_window_px < 0 || !(p.depth_sigma_per_m2 >= 0) ||
      !(p.depth_sigma_factor >= 0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "observed area: max_depth_m, free_ray_m, prefilter_voxel_m must be > 0, "
                "pixel_stride >= 1, free_ray_bound_window_px, depth_sigma_per_m2 and "
                "depth_sigma_factor >= 0");
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
    const auto coord = [](float v) {
      return static_cast<uint64_t>(static_cast<int64_t>(v) + (1 << 20));
    };
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
  return octomap::OcTreeKey(static_cast<octomap::key_type>(v >> 32),
                            static_cast<octomap::key_type>((v >> 16) & 0xffff),
                            static_cast<octomap::key_type>(v & 0xffff));
}

// Adds to `free` the voxels each ray from `origin` to an end point passes through (and the end
// voxel when end_free), on up to `threads` threads: OctoMap's own OpenMP path does nothing in
// Debian's build (see docs/design.md), and computeRayKeys is const. With `stop_before`, a ray
// ends before the first voxel of that set it meets (its end voxel is then not free either).
// Each thread collects into its own set, merged under a lock (the merged set is the same
// whatever the order).
void AddRayKeys(const octomap::OcTree& tree, const octomap::point3d& origin, const PointCloud& ends,
                bool end_free, const detail::FlatKeySet* stop_before, int threads,
                detail::FlatKeySet* free) {
  constexpr size_t kSerialBelow = 4096;  // rays: fewer are cast faster than a team wakes
  constexpr size_t kRaysPerClaim = 64;
  std::atomic<size_t> next{0};
  std::mutex merge_mutex;
  RunOnThreads(ends.size() > kSerialBelow ? threads : 1, [&](int) {
    detail::FlatKeySet local(4 * ends.size());
    octomap::KeyRay ray;
    for (size_t begin; (begin = next.fetch_add(kRaysPerClaim)) < ends.size();) {
      for (size_t i = begin, end = std::min(ends.size(), begin + kRaysPerClaim); i < end; ++i) {
        if (!tree.computeRayKeys(origin, ToOcto(ends[i]), ray)) continue;
        bool stopped = false;
        for (const auto& key : ray) {
          const uint64_t packed = Pack(key);
          if (stop_before && stop_before->Contains(packed)) {
            stopped = true;
            break;
          }
          local.Insert(packed);
        }
        octomap::OcTreeKey end_key;
        if (!end_free || stopped || !tree.coordToKeyChecked(ToOcto(ends[i]), end_key)) continue;
        const uint64_t packed = Pack(end_key);
        if (!stop_before || !stop_before->Contains(packed)) local.Insert(packed);
      }
    }
    const std::lock_guard lock(merge_mutex);
    local.ForEach([&](uint64_t key) { free->Insert(key); });
  });
}

// One keyframe's ray end points in the map frame, each kind reduced on the fly to one centroid
// per prefilter voxel (neighbouring pixels' rays cross the same voxels).
struct RayEnds {
  PointCloud hits;        // valid depth below th_d: the end voxel is occupied
  PointCloud hit_free;    // where the free part of a hit ray ends (the hit, or k sigma before it)
  PointCloud measured;    // depth beyond th_d: free up to min(depth, th_f), end voxel free
  PointCloud unmeasured;  // no depth: free up to th_f or the bound, end voxel free; with a prior
                          // also kept apart from `measured` (only these stop at prior surfaces)
};

RayEnds CollectRayEnds(const PinholeCamera& camera, const SE3& T_map_cam, const DepthImage& depth,
                       const ObservedAreaParams& params, bool separate_unmeasured) {
  const Eigen::Isometry3f T = T_map_cam.cast<float>();
  const float inv_fx = static_cast<float>(1.0 / camera.fx),
              inv_fy = static_cast<float>(1.0 / camera.fy);
  const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  const float max_depth = static_cast<float>(params.max_depth_m);
  const float free_depth = static_cast<float>(params.free_ray_m);
  const float sigma_k = static_cast<float>(params.depth_sigma_factor * params.depth_sigma_per_m2);
  const float leaf = static_cast<float>(params.prefilter_voxel_m);
  EndPointFilter hit_filter(leaf), hit_free_filter(leaf), measured_filter(leaf),
      unmeasured_filter(leaf);
  EndPointFilter& no_depth_filter = separate_unmeasured ? unmeasured_filter : measured_filter;
  const int stride = params.pixel_stride;
  const int nearest_cols = (camera.width + stride - 1) / stride;
  // The smallest valid depth within +-W pixels, read only at the strided pixels (window_min.hpp:
  // cv::erode with a 257x257 rectangle over the whole image was 26 % of a server commit's CPU).
  const std::vector<float> nearest =
      params.free_ray_bound_window_px > 0
          ? NearestDepthAround(depth, params.free_ray_bound_window_px, stride)
          : std::vector<float>();
  for (int v = 0; v < camera.height; v += stride) {
    const float y = (static_cast<float>(v) - cy) * inv_fy;
    for (int u = 0; u < camera.width; u += stride) {
      const float x = (static_cast<float>(u) - cx) * inv_fx;
      const auto at_depth = [&](float z) { return T * Point(x * z, y * z, z); };
      const float d = depth.at(u, v);
      const bool valid = std::isfinite(d) && d > 0.f;
      if (valid && d < max_depth) {
        hit_filter.Add(at_depth(d));
        // The free part ends k sigma(d) before the hit (sigma grows with d^2).
        const float free_until = d - sigma_k * d * d;
        if (sigma_k > 0.f && free_until > 0.f) hit_free_filter.Add(at_depth(free_until));
      } else if (valid) {
        // A depth beyond th_d still says the space before it is free: never cast past it.
        measured_filter.Add(at_depth(std::min(d, free_depth)));
      } else {
        // Without depth: th_f (paper), or with the bound no further than the nearest surface
        // seen around the pixel (nearest[] is +inf when the window holds no depth).
        const float no_depth =
            nearest.empty()
                ? free_depth
                : std::min(free_depth,
                           nearest[static_cast<size_t>(v / stride) * nearest_cols + u / stride]);
        no_depth_filter.Add(at_depth(no_depth));
      }
    }
  }
  RayEnds ends{
      hit_filter.Centroids(), {}, measured_filter.Centroids(), unmeasured_filter.Centroids()};
  // Without the depth uncertainty the free part of a hit ray ends at the hit (the paper).
  ends.hit_free = sigma_k > 0.f ? hit_free_filter.Centroids() : ends.hits;
  return ends;
}

}  // namespace

ObservedArea::ObservedArea(double resolution_m) {
  if (!(std::isfinite(resolution_m) && resolution_m >= 1e-3)) {
    throw Error(ErrorCode::kInvalidArgument, "observed area: resolution must be >= 1 mm");
  }
  impl_ = std::make_unique<Impl>(resolution_m);
}
ObservedArea::~ObservedArea() = default;
ObservedArea::ObservedArea(const ObservedArea& other)
    : impl_(std::make_unique<Impl>(*other.impl_)) {}
ObservedArea& ObservedArea::operator=(const ObservedArea& other) {
  if (this != &other) impl_ = std::make_unique<Impl>(*other.impl_);
  return *this;
}
ObservedArea::ObservedArea(ObservedArea&&) noexcept = default;
ObservedArea& ObservedArea::operator=(ObservedArea&&) noexcept = default;

void ObservedArea::InsertKeyframe(const PinholeCamera& camera, const SE3& T_map_cam,
                                  const DepthImage& depth, const ObservedAreaParams& params,
                                  const PriorSurfaces* prior) {
  CheckParams(camera, depth, params);
  if (!IsValidPose(T_map_cam, 1e-4)) {
    throw Error(ErrorCode::kInvalidArgument,
                "observed area: T_map_cam is not a valid rigid transform");
  }
  auto& tree = impl_->tree;
  if (prior && std::abs(prior->resolution_m() - tree.getResolution()) > 1e-9) {
    throw Error(ErrorCode::kInvalidArgument, "observed area: prior surfaces at resolution " +
                                                 std::to_string(prior->resolution_m()) +
                                                 ", octree at " +
                                                 std::to_string(tree.getResolution()));
  }
  // 1-2. End points in the map frame, prefiltered per kind.
  const RayEnds ends = CollectRayEnds(camera, T_map_cam, depth, params, prior != nullptr);

  // 3. Voxel keys: end voxels of hits are occupied; all other traversed voxels (and the end
  //    voxels of free rays) are free, unless some hit ended there (as OctoMap's discretized
  //    insertPointCloud does). Rays without depth stop before the prior's surfaces.
  const octomap::point3d origin = ToOcto(T_map_cam.translation().cast<float>());
  detail::FlatKeySet occupied(ends.hits.size());
  for (const auto& p : ends.hits) {
    octomap::OcTreeKey key;
    if (tree.coordToKeyChecked(ToOcto(p), key)) occupied.Insert(Pack(key));
  }
  detail::FlatKeySet free(8 *
                          (ends.hit_free.size() + ends.measured.size() + ends.unmeasured.size()));
  const int threads = params.threads;
  AddRayKeys(tree, origin, ends.hit_free, /*end_free=*/false, nullptr, threads, &free);
  AddRayKeys(tree, origin, ends.measured, /*end_free=*/true, nullptr, threads, &free);
  AddRayKeys(tree, origin, ends.unmeasured, /*end_free=*/true,
             prior ? &prior->impl_->voxels : nullptr, threads, &free);
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

bool ObservedArea::IsSeenFree(const Point& p_map, int keyframes) const {
  if (keyframes < 1 || keyframes > 4) {
    throw Error(ErrorCode::kInvalidArgument,
                "observed area: IsSeenFree needs 1-4 keyframes (OctoMap clamps)");
  }
  if (!p_map.allFinite()) return false;
  const octomap::OcTreeNode* node = impl_->tree.search(ToOcto(p_map));
  // A little slack: log-odds are floats summed over keyframes.
  return node && node->getLogOdds() <= keyframes * impl_->tree.getProbMissLog() + 1e-4f;
}

PriorSurfaces::PriorSurfaces(const PointCloud& prior_map, double resolution_m)
    : resolution_m_(resolution_m) {
  if (!(std::isfinite(resolution_m) && resolution_m >= 1e-3)) {
    throw Error(ErrorCode::kInvalidArgument, "prior surfaces: resolution must be >= 1 mm");
  }
  impl_ = std::make_unique<Impl>(resolution_m, prior_map.size());
  for (const Point& p : prior_map) {
    octomap::OcTreeKey key;
    if (p.allFinite() && impl_->grid.coordToKeyChecked(ToOcto(p), key))
      impl_->voxels.Insert(Pack(key));
  }
}
PriorSurfaces::~PriorSurfaces() = default;
PriorSurfaces::PriorSurfaces(PriorSurfaces&&) noexcept = default;
PriorSurfaces& PriorSurfaces::operator=(PriorSurfaces&&) noexcept = default;
size_t PriorSurfaces::NumVoxels() const { return impl_->voxels.size(); }
bool PriorSurfaces::Contains(const Point& p_map) const {
  octomap::OcTreeKey key;
  return p_map.allFinite() && impl_->grid.coordToKeyChecked(ToOcto(p_map), key) &&
         impl_->voxels.Contains(Pack(key));
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
  for (auto it = other.impl_->tree.begin_leafs(), end = other.impl_->tree.end_leafs(); it != end;
       ++it) {
    const float log_odds = it->getLogOdds();
    if (it.getDepth() == max_depth) {
      tree.updateNode(it.getKey(), log_odds, true);
      continue;
    }
    // A pruned leaf stands for a cube of identical voxels: add each of them.
    const int n = 1 << (max_depth - it.getDepth());
    const octomap::point3d corner =
        it.getCoordinate() - octomap::point3d(1, 1, 1) * (it.getSize() / 2);
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

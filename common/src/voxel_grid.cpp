#include "mapdelta/common/voxel_grid.hpp"

#include <cmath>
#include <vector>

#include "flat_key_set.hpp"
#include "mapdelta/common/error.hpp"

namespace mapdelta {
namespace {

struct Accumulator {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  uint32_t count = 0;
};

// 21 bits per axis: +-1,048,576 voxels, i.e. +-419 km at 0.4 m.
uint64_t PackKey(int64_t x, int64_t y, int64_t z) {
  constexpr int64_t kOffset = 1 << 20;
  constexpr uint64_t kMask = (1u << 21) - 1;
  return ((static_cast<uint64_t>(x + kOffset) & kMask) << 42) |
         ((static_cast<uint64_t>(y + kOffset) & kMask) << 21) |
         (static_cast<uint64_t>(z + kOffset) & kMask);
}

}  // namespace

PointCloud VoxelDownsample(const PointCloud& cloud, float leaf_m) {
  return VoxelDownsample(cloud, leaf_m, nullptr);
}

PointCloud VoxelDownsample(const PointCloud& cloud, float leaf_m, std::vector<uint32_t>* counts) {
  if (!(leaf_m > 0.f) || !std::isfinite(leaf_m)) {
    throw Error(ErrorCode::kInvalidArgument, "voxel leaf size must be positive");
  }
  const double inv = 1.0 / leaf_m;
  // Voxel key -> accumulator index, in first-seen order (keeps the output deterministic).
  detail::FlatKeyIndex voxel_of_key(cloud.size() / 4 + 16);
  std::vector<Accumulator> voxels;
  for (const auto& p : cloud) {
    if (!p.allFinite()) continue;
    const uint64_t key = PackKey(static_cast<int64_t>(std::floor(p.x() * inv)),
                                 static_cast<int64_t>(std::floor(p.y() * inv)),
                                 static_cast<int64_t>(std::floor(p.z() * inv)));
    const auto [index, inserted] = voxel_of_key.Insert(key);
    if (inserted) voxels.emplace_back();
    voxels[index].sum += p.cast<double>();
    ++voxels[index].count;
  }
  PointCloud out(voxels.size());
  for (size_t i = 0; i < voxels.size(); ++i)
    out[i] = (voxels[i].sum / voxels[i].count).cast<float>();
  if (counts) {
    counts->resize(voxels.size());
    for (size_t i = 0; i < voxels.size(); ++i) (*counts)[i] = voxels[i].count;
  }
  return out;
}

}  // namespace mapdelta

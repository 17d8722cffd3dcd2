#include "mapdelta/sim/cloud_sampler.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta::sim {
namespace {

// Boxes bucketed on a 2D grid, to test "inside some other box" quickly.
class BoxIndex {
 public:
  BoxIndex(const Scene& s, const Object* extra) {
    for (const Object& o : s.objects) Add(o);
    if (extra) Add(*extra);
  }
  // Boxes in the cells that b's footprint touches (may repeat; callers filter by overlap).
  std::vector<const Box*> Near(const Box& b) const {
    std::vector<const Box*> out;
    for (double x = std::floor(b.min.x() / kCell); x <= std::floor(b.max.x() / kCell); ++x) {
      for (double y = std::floor(b.min.y() / kCell); y <= std::floor(b.max.y() / kCell); ++y) {
        const auto it = cells_.find(Key(x * kCell + 0.5 * kCell, y * kCell + 0.5 * kCell));
        if (it != cells_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
      }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
  bool UnderSomething(double x, double y) const {
    const auto it = cells_.find(Key(x, y));
    if (it == cells_.end()) return false;
    for (const Box* b : it->second) {
      if (b->min.z() <= 1e-6 && x > b->min.x() && x < b->max.x() && y > b->min.y() &&
          y < b->max.y())
        return true;
    }
    return false;
  }

 private:
  static constexpr double kCell = 8.0;
  static int64_t Key(double x, double y) {
    return (static_cast<int64_t>(std::floor(x / kCell)) << 32) ^
           (static_cast<int64_t>(std::floor(y / kCell)) & 0xffffffff);
  }
  void Add(const Object& o) {
    for (const Box& b : o.boxes) {
      for (double x = std::floor(b.min.x() / kCell); x <= std::floor(b.max.x() / kCell); ++x) {
        for (double y = std::floor(b.min.y() / kCell); y <= std::floor(b.max.y() / kCell); ++y) {
          cells_[Key(x * kCell + 0.5 * kCell, y * kCell + 0.5 * kCell)].push_back(&b);
        }
      }
    }
  }
  std::unordered_map<int64_t, std::vector<const Box*>> cells_;
};

// Samples one face (axis `axis` fixed at `value`) of box b on a grid of step h.
void SampleFace(const Box& b, int axis, double value, double h,
                const std::vector<const Box*>& others, PointCloud* out) {
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  // Only boxes overlapping this face can bury part of it.
  std::vector<const Box*> near;
  for (const Box* o : others) {
    if (o == &b) continue;
    bool overlap = o->min[axis] < value && value < o->max[axis];
    for (int a : {a1, a2}) overlap = overlap && o->min[a] < b.max[a] && b.min[a] < o->max[a];
    if (overlap) near.push_back(o);
  }
  const int n1 = std::max(1, static_cast<int>(std::ceil((b.max[a1] - b.min[a1]) / h)));
  const int n2 = std::max(1, static_cast<int>(std::ceil((b.max[a2] - b.min[a2]) / h)));
  for (int i = 0; i <= n1; ++i) {
    for (int j = 0; j <= n2; ++j) {
      Eigen::Vector3d p;
      p[axis] = value;
      p[a1] = b.min[a1] + (b.max[a1] - b.min[a1]) * i / n1;
      p[a2] = b.min[a2] + (b.max[a2] - b.min[a2]) * j / n2;
      bool buried = false;
      for (const Box* o : near) buried = buried || o->ContainsStrict(p, 1e-4);
      if (!buried) out->push_back(p.cast<float>());
    }
  }
}

void SampleObject(const Object& o, double h, const BoxIndex& index, PointCloud* out) {
  for (const Box& b : o.boxes) {
    const std::vector<const Box*> others = index.Near(b);
    for (int axis = 0; axis < 3; ++axis) {
      // Bottom faces on the ground are never seen.
      if (axis != 2 || b.min.z() > 1e-3) SampleFace(b, axis, b.min[axis], h, others, out);
      SampleFace(b, axis, b.max[axis], h, others, out);
    }
  }
}

}  // namespace

PointCloud SampleSceneCloud(const Scene& s, double leaf) {
  const double h = 0.5 * leaf;
  const BoxIndex index(s, nullptr);
  PointCloud result;
  // Ground in strips of whole voxels, downsampled strip by strip to bound memory.
  const double x0 = -0.5 * s.extent_x, x1 = 0.5 * s.extent_x, y0 = -0.5 * s.extent_y,
               y1 = 0.5 * s.extent_y;
  const double strip = leaf * std::ceil(10.0 / leaf);
  for (double sy = std::floor(y0 / strip) * strip; sy < y1; sy += strip) {
    PointCloud dense;
    for (double y = std::max(sy, y0); y < std::min(sy + strip, y1); y += h) {
      for (double x = x0; x < x1; x += h) {
        if (!index.UnderSomething(x, y))
          dense.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.f);
      }
    }
    const PointCloud down = VoxelDownsample(dense, static_cast<float>(leaf));
    result.insert(result.end(), down.begin(), down.end());
  }
  PointCloud objects;
  for (const Object& o : s.objects) SampleObject(o, h, index, &objects);
  const PointCloud down = VoxelDownsample(objects, static_cast<float>(leaf));
  result.insert(result.end(), down.begin(), down.end());
  return result;
}

PointCloud SampleObjectCloud(const Scene& s, const Object& o, double leaf) {
  const bool in_scene = s.Find(o.id) != nullptr;
  const BoxIndex index(s, in_scene ? nullptr : &o);
  PointCloud dense;
  SampleObject(o, 0.5 * leaf, index, &dense);
  return VoxelDownsample(dense, static_cast<float>(leaf));
}

}  // namespace mapdelta::sim

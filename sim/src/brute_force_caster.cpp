// Slab-test ray casting against every box: O(boxes) per ray. The test oracle and the
// benchmark baseline for EmbreeCaster.
#include <algorithm>
#include <cmath>
#include <limits>

#include "mapdelta/sim/raycaster.hpp"

namespace mapdelta::sim {

BruteForceCaster::BruteForceCaster(const Scene& s) {
  for (size_t oi = 0; oi < s.objects.size(); ++oi) {
    const auto& boxes = s.objects[oi].boxes;
    for (size_t bi = 0; bi < boxes.size(); ++bi) {
      boxes_.push_back({boxes[bi].min.cast<float>(), boxes[bi].max.cast<float>(),
                        static_cast<int>(oi), static_cast<int>(bi)});
    }
  }
  ground_min_ = Eigen::Vector2f(static_cast<float>(-0.5 * s.extent_x - kGroundMargin),
                                static_cast<float>(-0.5 * s.extent_y - kGroundMargin));
  ground_max_ = Eigen::Vector2f(static_cast<float>(0.5 * s.extent_x + kGroundMargin),
                                static_cast<float>(0.5 * s.extent_y + kGroundMargin));
}

bool BruteForceCaster::Intersect(const Eigen::Vector3f& o, const Eigen::Vector3f& d, float tnear,
                                 float tfar, Hit* hit) const {
  bool found = false;
  float best = tfar;
  // Ground plane z = 0 within its finite extent.
  if (d.z() != 0.f) {
    const float t = -o.z() / d.z();
    const Eigen::Vector3f p = o + t * d;
    if (t > tnear && t < best && p.x() >= ground_min_.x() && p.x() <= ground_max_.x() &&
        p.y() >= ground_min_.y() && p.y() <= ground_max_.y()) {
      best = t;
      found = true;
      hit->object = -1;
      hit->box = -1;
      hit->normal = Eigen::Vector3f::UnitZ();
    }
  }
  for (const Entry& b : boxes_) {
    // Slab test; the entry face is the axis whose near plane is crossed last. Rays starting
    // inside a box see its far faces (as the triangle mesh does).
    float t0 = -std::numeric_limits<float>::infinity(), t1 = std::numeric_limits<float>::infinity();
    int axis0 = -1, axis1 = -1;
    bool miss = false;
    for (int a = 0; a < 3; ++a) {
      if (d[a] == 0.f) {
        if (o[a] < b.min[a] || o[a] > b.max[a]) miss = true;
        continue;
      }
      float ta = (b.min[a] - o[a]) / d[a], tb = (b.max[a] - o[a]) / d[a];
      if (ta > tb) std::swap(ta, tb);
      if (ta > t0) {
        t0 = ta;
        axis0 = a;
      }
      if (tb < t1) {
        t1 = tb;
        axis1 = a;
      }
    }
    if (miss || t0 > t1) continue;
    float t = t0;
    int axis = axis0;
    float sign = d[axis0 < 0 ? 0 : axis0] > 0 ? -1.f : 1.f;
    if (!(t > tnear)) {  // origin inside (or box behind): use the exit face
      t = t1;
      axis = axis1;
      sign = axis1 >= 0 && d[axis1] > 0 ? 1.f : -1.f;
    }
    if (axis < 0 || !(t > tnear) || !(t < best)) continue;
    best = t;
    found = true;
    hit->object = b.object;
    hit->box = b.box;
    hit->normal = Eigen::Vector3f::Zero();
    hit->normal[axis] = sign;
  }
  if (found) hit->t = best;
  return found;
}

bool BruteForceCaster::Occluded(const Eigen::Vector3f& o, const Eigen::Vector3f& d, float tnear,
                                float tfar) const {
  Hit h;
  return Intersect(o, d, tnear, tfar, &h);
}

}  // namespace mapdelta::sim

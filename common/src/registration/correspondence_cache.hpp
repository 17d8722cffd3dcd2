#pragma once
// Nearest target point per source point across GICP iterations, exact, with most searches
// skipped once the pose settles.
//
// Each search records the two nearest target points (distances d0 <= d1) at the query
// position a. When the source point has since moved to q, |q - a| = m, the old nearest point
// is within d0 + m and every other point is farther than d1 - m, so if d0 + m < d1 - m the
// answer is unchanged and no search is needed. A search that finds nothing within the radius
// R = max_distance + cushion proves "no target point within R - m", so the point stays an
// outlier while R - m > max_distance. A new search is bounded by the distance to the two
// points of the last search (or, for the first search, of the previous source point): both lie
// inside the bound, so the two nearest are still found, with far less backtracking.
//
// Measured on bench_registration (0.25 m LiDAR pair from identity, 2026-12-01): 15533
// searches for 24668 look-ups over 4 passes; the passes after steps of 47 cm, 3.7 cm and
// 2.1 mm searched 98%, 47% and 7% of the points.
#include <cmath>
#include <cstdint>
#include <vector>

#include "kd_tree.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta::detail {

class CorrespondenceCache {
 public:
  static constexpr uint32_t kNone = KdTree::kNone;
  // Outliers are searched this much (relative) beyond max_distance, which lets them stay
  // outliers without a search while they move less than the difference.
  static constexpr float kOutlierCushion = 0.1f;

  CorrespondenceCache(size_t num_source, float max_distance)
      : entries_(num_source),
        max_distance_(max_distance),
        radius_(max_distance * (1.f + kOutlierCushion)) {}

  // Nearest target index strictly within max_distance of q (source point i at the current
  // pose), or kNone; *distance is set for a match. hint: the source point searched just before
  // in the same thread (its entry seeds the bound), or kNone. Each i from one thread only.
  uint32_t Find(size_t i, const Point& q, size_t hint, const PointCloud& target, const KdTree& tree,
                float* distance) {
    Entry& e = entries_[i];
    float bound = radius_;
    if (e.valid) {
      const float moved = (q - e.anchor).norm();
      if (e.index[0] == kNone) {
        if (e.distance[0] - moved > max_distance_) return kNone;  // still nothing in range
      } else if (e.distance[0] + moved < e.distance[1] - moved - Slack(q)) {
        return Match(e.index[0], q, target, distance);
      }
      bound = SeedBound(e, q, target);
    } else if (hint != kNone && entries_[hint].valid) {
      bound = SeedBound(entries_[hint], q, target);
    }
    Search(q, bound, tree, &e);
    return e.index[0] == kNone ? kNone : Match(e.index[0], q, target, distance);
  }

  size_t searches() const {
    size_t n = 0;
    for (const Entry& e : entries_) n += e.searches;
    return n;
  }

 private:
  struct Entry {
    Point anchor = Point::Zero();  // query position of the last search
    uint32_t index[2] = {kNone, kNone};
    float distance[2] = {0, 0};  // exact, or the search radius (a lower bound) for kNone
    bool valid = false;
    uint32_t searches = 0;
  };

  // Rounding of float distances at this coordinate magnitude: a margin so that "unchanged"
  // never disagrees with what a fresh search would return.
  static float Slack(const Point& q) { return 4e-7f * (1.f + q.cwiseAbs().maxCoeff()); }

  uint32_t Match(uint32_t j, const Point& q, const PointCloud& target, float* distance) const {
    const float d = (target[j] - q).norm();
    if (!(d < max_distance_)) return kNone;
    *distance = d;
    return j;
  }

  // A radius that contains the two points recorded in e (so two are found), or radius_.
  float SeedBound(const Entry& e, const Point& q, const PointCloud& target) const {
    if (e.index[1] == kNone) return radius_;
    const float d = std::max((target[e.index[0]] - q).norm(), (target[e.index[1]] - q).norm());
    return std::min(radius_, d * 1.0001f + Slack(q));
  }

  void Search(const Point& q, float bound, const KdTree& tree, Entry* e) const {
    float d2[2];
    tree.TwoNearestWithin(q, bound, e->index, d2);
    // Not found: nothing within bound, which may be less than radius_ only if two seeds were
    // found, so kNone entries always carry radius_ (bound == radius_ then).
    e->distance[0] = std::sqrt(d2[0]);
    e->distance[1] = std::sqrt(d2[1]);
    e->anchor = q;
    e->valid = true;
    ++e->searches;
  }

  std::vector<Entry> entries_;
  float max_distance_;
  float radius_;
};

}  // namespace mapdelta::detail

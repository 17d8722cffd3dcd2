#pragma once
// Nearest-neighbour and radius queries over a fixed cloud (a k-d tree; nanoflann inside).
// The index keeps a reference to the cloud: the cloud must outlive it and not change.
#include <memory>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

class NeighborIndex {
 public:
  explicit NeighborIndex(const PointCloud& cloud);
  ~NeighborIndex();
  NeighborIndex(NeighborIndex&&) noexcept;
  NeighborIndex& operator=(NeighborIndex&&) noexcept;

  bool empty() const;
  // Index of the nearest point and the Euclidean distance to it; returns false if empty.
  bool Nearest(const Point& query, size_t* index, float* distance) const;
  // Nearest point strictly closer than max_distance; false if there is none. The bound prunes
  // the tree walk: a known upper bound (e.g. the distance to last iteration's match in ICP)
  // makes the query much cheaper than Nearest().
  bool NearestWithin(const Point& query, float max_distance, size_t* index, float* distance) const;
  // Distance to the nearest point (infinity when empty).
  float NearestDistance(const Point& query) const;
  // True if some point lies within radius (distance <= radius, or < radius when !inclusive).
  // Stops at the first such point: much cheaper than Nearest() for threshold tests.
  bool AnyWithin(const Point& query, float radius, bool inclusive = true) const;
  // Indices of all points within radius (unsorted).
  std::vector<size_t> RadiusSearch(const Point& query, float radius) const;
  // k nearest indices, closest first.
  std::vector<size_t> KNearest(const Point& query, size_t k) const;
  // Nearest distance for every query point, on `threads` threads (0 = every hardware thread).
  std::vector<float> NearestDistances(const PointCloud& queries, int threads) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mapdelta

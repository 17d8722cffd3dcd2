#include "mapdelta/common/neighbor_index.hpp"

#include <nanoflann.hpp>

#include <cmath>
#include <limits>

#include "mapdelta/common/parallel.hpp"

namespace mapdelta {
namespace {

struct CloudAdaptor {
  const PointCloud* cloud;
  size_t kdtree_get_point_count() const { return cloud->size(); }
  float kdtree_get_pt(size_t i, size_t dim) const { return (*cloud)[i][static_cast<int>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

// Result set that ends the search at the first point inside the radius. nanoflann offers a
// point only when its squared distance is < worstDist(), so the inclusive test raises the
// bound to the next float above radius^2.
class AnyWithinResultSet {
 public:
  AnyWithinResultSet(float radius_sq, bool inclusive)
      : bound_(inclusive ? std::nextafter(radius_sq, std::numeric_limits<float>::infinity())
                         : radius_sq) {}
  size_t size() const { return found_ ? 1 : 0; }
  bool full() const { return true; }
  bool addPoint(float dist_sq, size_t) {
    found_ = found_ || dist_sq < bound_;
    return !found_;  // false stops the search
  }
  float worstDist() const { return bound_; }
  bool found() const { return found_; }

 private:
  float bound_;
  bool found_ = false;
};

using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, CloudAdaptor>,
                                        CloudAdaptor, 3, size_t>;

}  // namespace

struct NeighborIndex::Impl {
  CloudAdaptor adaptor;
  KdTree tree;
  explicit Impl(const PointCloud& cloud)
      : adaptor{&cloud}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
    tree.buildIndex();
  }
};

NeighborIndex::NeighborIndex(const PointCloud& cloud) : impl_(std::make_unique<Impl>(cloud)) {}
NeighborIndex::~NeighborIndex() = default;
NeighborIndex::NeighborIndex(NeighborIndex&&) noexcept = default;
NeighborIndex& NeighborIndex::operator=(NeighborIndex&&) noexcept = default;

bool NeighborIndex::empty() const { return impl_->adaptor.cloud->empty(); }

bool NeighborIndex::Nearest(const Point& query, size_t* index, float* distance) const {
  if (empty()) return false;
  size_t i = 0;
  float d2 = 0.f;
  nanoflann::KNNResultSet<float, size_t> result(1);
  result.init(&i, &d2);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  *index = i;
  *distance = std::sqrt(d2);
  return true;
}

bool NeighborIndex::NearestWithin(const Point& query, float max_distance, size_t* index,
                                  float* distance) const {
  if (empty() || !(max_distance > 0.f)) return false;
  size_t i = 0;
  float d2 = 0.f;
  nanoflann::KNNResultSet<float, size_t> result(1);
  result.init(&i, &d2);
  d2 = max_distance * max_distance;  // worstDist(): only strictly closer points are taken
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  if (result.size() == 0) return false;
  *index = i;
  *distance = std::sqrt(d2);
  return true;
}

float NeighborIndex::NearestDistance(const Point& query) const {
  size_t i = 0;
  float d = std::numeric_limits<float>::infinity();
  Nearest(query, &i, &d);
  return d;
}

bool NeighborIndex::AnyWithin(const Point& query, float radius, bool inclusive) const {
  if (empty() || !(radius >= 0.f)) return false;
  AnyWithinResultSet result(radius * radius, inclusive);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  return result.found();
}

std::vector<size_t> NeighborIndex::RadiusSearch(const Point& query, float radius) const {
  std::vector<std::pair<size_t, float>> matches;
  std::vector<size_t> out;
  if (empty()) return out;
  nanoflann::SearchParams params;
  params.sorted = false;
  impl_->tree.radiusSearch(query.data(), radius * radius, matches, params);
  out.reserve(matches.size());
  for (const auto& m : matches) out.push_back(m.first);
  return out;
}

std::vector<size_t> NeighborIndex::KNearest(const Point& query, size_t k) const {
  std::vector<size_t> indices(k);
  std::vector<float> d2(k);
  if (empty() || k == 0) return {};
  const size_t found = impl_->tree.knnSearch(query.data(), k, indices.data(), d2.data());
  indices.resize(found);
  return indices;
}

std::vector<float> NeighborIndex::NearestDistances(const PointCloud& queries, int threads) const {
  std::vector<float> out(queries.size(), std::numeric_limits<float>::infinity());
  if (empty()) return out;
  ParallelFor(
      queries.size(), threads, [&](size_t i) { out[i] = NearestDistance(queries[i]); }, 1024);
  return out;
}

}  // namespace mapdelta

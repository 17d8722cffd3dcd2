#include "covariance_estimation.hpp"

#include <cmath>
#include <cstdint>

#include "mapdelta/common/parallel.hpp"
#include "mapdelta/common/registration/gicp_factor.hpp"
#include "sorted_cells.hpp"

namespace mapdelta::detail {
namespace {

// Count, sum (x, y, z) and sum of products (xx, xy, xz, yy, yz, zz) of points: one vector of
// 10 doubles, so that merging cells is one vector addition.
struct Moments {
  using Vector10d = Eigen::Matrix<double, 10, 1>;
  Vector10d v = Vector10d::Zero();
  void Add(const Eigen::Vector3d& p) {
    const double x = p.x(), y = p.y(), z = p.z();
    v(0) += 1;
    v(1) += x;
    v(2) += y;
    v(3) += z;
    v(4) += x * x;
    v(5) += x * y;
    v(6) += x * z;
    v(7) += y * y;
    v(8) += y * z;
    v(9) += z * z;
  }
  void Add(const Moments& m) { v += m.v; }
  double n() const { return v(0); }
};

// Plane normal of the sample covariance from moments; zero (isotropic) when shapeless.
Eigen::Vector3f Normal(const Moments& m) {
  if (m.n() < 5) return Eigen::Vector3f::Zero();
  const Eigen::Vector3d mean = m.v.segment<3>(1) / m.n();
  Eigen::Matrix3d outer;
  outer << m.v(4), m.v(5), m.v(6), m.v(5), m.v(7), m.v(8), m.v(6), m.v(8), m.v(9);
  const Eigen::Matrix3d cov = outer / m.n() - mean * mean.transpose();
  if (!(cov.trace() > 1e-12) || !cov.allFinite()) return Eigen::Vector3f::Zero();
  return PlaneNormal(cov).cast<float>();
}

Eigen::Vector3f KNearestNormal(const PointCloud& points, const KdTree& tree, const Point& query,
                               size_t k) {
  // Centred on the query point's neighbourhood mean; moments in double are exact enough
  // after subtracting the query (clouds may be in map coordinates far from the origin).
  const Eigen::Vector3d origin = query.cast<double>();
  Moments m;
  for (size_t i : tree.KNearest(query, k)) m.Add(points[i].cast<double>() - origin);
  return Normal(m);
}

}  // namespace

std::vector<Eigen::Vector3f> NormalsKNearest(const PointCloud& points, const KdTree& tree, size_t k,
                                             int num_threads) {
  std::vector<Eigen::Vector3f> out(points.size());
  ParallelRanges(points.size(), num_threads, 0, [&](size_t begin, size_t end, int&) {
    for (size_t i = begin; i < end; ++i) out[i] = KNearestNormal(points, tree, points[i], k);
  });
  return out;
}

std::vector<Eigen::Vector3f> NormalsVoxelBlock(const PointCloud& points, double cell_m,
                                               int num_threads) {
  std::vector<Eigen::Vector3f> out(points.size());
  if (points.empty()) return out;
  // 1. Cells of the grid through the coordinate origin (aligned with the voxels of voxel_m,
  // whatever the point order), counted from its grid point nearest the first point; moments
  // relative to that point (precision far from the origin).
  const Eigen::Vector3d origin =
      ((points.front().cast<double>() / cell_m).array().floor() * cell_m).matrix();
  const SortedCells cells(points, origin, cell_m, 1);
  std::vector<Moments> cell_moments(cells.size());
  for (size_t c = 0; c < cells.size(); ++c) {
    for (const uint32_t* i = cells.PointsBegin(c); i != cells.PointsEnd(c); ++i) {
      cell_moments[c].Add(points[*i].cast<double>() - origin);
    }
  }
  // 2. Block moments per occupied cell, then its normal.
  std::vector<Moments> blocks(cells.size());
  std::vector<uint32_t> all(cells.size());
  for (size_t c = 0; c < cells.size(); ++c) all[c] = static_cast<uint32_t>(c);
  cells.ForEachInBlock(all, 1, [&](size_t c, size_t n) { blocks[c].Add(cell_moments[n]); });
  std::vector<Eigen::Vector3f> cell_normal(cells.size());
  ParallelRanges(cells.size(), num_threads, 0, [&](size_t begin, size_t end, int&) {
    for (size_t c = begin; c < end; ++c) {
      cell_normal[c] =
          blocks[c].n() < kMinBlockPoints ? Eigen::Vector3f::Zero() : Normal(blocks[c]);
    }
  });
  // 3. Points take their cell's normal.
  for (size_t i = 0; i < points.size(); ++i) out[i] = cell_normal[cells.CellOf(i)];
  return out;
}

}  // namespace mapdelta::detail

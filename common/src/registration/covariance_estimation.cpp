#include "covariance_estimation.hpp"

#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "mapdelta/common/log.hpp"
#include "mapdelta/common/registration/gicp_factor.hpp"
#include "parallel.hpp"

namespace mapdelta::detail {
namespace {

struct Moments {
  double n = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  void Add(const Eigen::Vector3d& p) {
    n += 1;
    sum += p;
    outer.noalias() += p * p.transpose();
  }
  void Add(const Moments& m) {
    n += m.n;
    sum += m.sum;
    outer += m.outer;
  }
};

// Sample covariance from moments, plane-regularized; isotropic unit when shapeless.
Eigen::Matrix3f Regularized(const Moments& m) {
  if (m.n < 5) return Eigen::Matrix3f::Identity();
  const Eigen::Vector3d mean = m.sum / m.n;
  const Eigen::Matrix3d cov = m.outer / m.n - mean * mean.transpose();
  if (!(cov.trace() > 1e-12) || !cov.allFinite()) return Eigen::Matrix3f::Identity();
  return RegularizePlaneCovariance(cov).cast<float>();
}

Eigen::Matrix3f KNearestCovariance(const PointCloud& points, const NeighborIndex& index,
                                   const Point& query, size_t k) {
  // Centred on the query point's neighbourhood mean; moments in double are exact enough
  // after subtracting the query (clouds may be in map coordinates far from the origin).
  const Eigen::Vector3d origin = query.cast<double>();
  Moments m;
  for (size_t i : index.KNearest(query, k)) m.Add(points[i].cast<double>() - origin);
  return Regularized(m);
}

// 21 bits per axis, as voxel_grid.cpp: +-1,048,576 cells.
uint64_t PackCell(const Eigen::Vector3i& c) {
  constexpr int64_t kOffset = 1 << 20;
  constexpr uint64_t kMask = (1u << 21) - 1;
  return ((static_cast<uint64_t>(c.x() + kOffset) & kMask) << 42) |
         ((static_cast<uint64_t>(c.y() + kOffset) & kMask) << 21) |
         (static_cast<uint64_t>(c.z() + kOffset) & kMask);
}

}  // namespace

std::vector<Eigen::Matrix3f> CovariancesKNearest(const PointCloud& points,
                                                 const NeighborIndex& index, size_t k,
                                                 int num_threads) {
  std::vector<Eigen::Matrix3f> out(points.size());
  ParallelRanges(points.size(), num_threads, 0, [&](size_t begin, size_t end, int&) {
    for (size_t i = begin; i < end; ++i) out[i] = KNearestCovariance(points, index, points[i], k);
  });
  return out;
}

std::vector<Eigen::Matrix3f> CovariancesVoxelBlock(const PointCloud& points,
                                                   const NeighborIndex& index, double cell_m,
                                                   size_t k, int num_threads) {
  std::vector<Eigen::Matrix3f> out(points.size());
  if (points.empty()) return out;
  // 1. Cell of every point and per-cell moments, relative to the first point (precision).
  const Eigen::Vector3d origin = points.front().cast<double>();
  const double inv = 1.0 / cell_m;
  std::vector<uint32_t> cell_of(points.size());
  std::vector<Eigen::Vector3i> cell_coords;
  std::vector<Moments> cell_moments;
  std::unordered_map<uint64_t, uint32_t> cell_index;
  cell_index.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = points[i].cast<double>() - origin;
    const Eigen::Vector3i c = (p * inv).array().floor().cast<int>();
    auto [it, inserted] = cell_index.try_emplace(PackCell(c), cell_moments.size());
    if (inserted) {
      cell_coords.push_back(c);
      cell_moments.emplace_back();
    }
    cell_moments[it->second].Add(p);
    cell_of[i] = it->second;
  }
  // 2. Block covariance per occupied cell from its 27 neighbours (empty = kNN fallback).
  std::vector<Eigen::Matrix3f> cell_cov(cell_moments.size());
  std::vector<uint8_t> cell_sparse(cell_moments.size(), 0);  // not vector<bool>: written in parallel
  ParallelRanges(cell_moments.size(), num_threads, 0, [&](size_t begin, size_t end, int&) {
    for (size_t c = begin; c < end; ++c) {
      Moments block;
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = cell_index.find(PackCell(cell_coords[c] + Eigen::Vector3i(dx, dy, dz)));
            if (it != cell_index.end()) block.Add(cell_moments[it->second]);
          }
        }
      }
      if (block.n < kMinBlockPoints) {
        cell_sparse[c] = 1;
      } else {
        cell_cov[c] = Regularized(block);
      }
    }
  });
  size_t sparse = 0;
  for (size_t i = 0; i < points.size(); ++i) sparse += cell_sparse[cell_of[i]];
  MD_LOG(kDebug, "voxel-block covariances: " << cell_moments.size() << " cells, " << sparse << "/"
                                             << points.size() << " points use k nearest");
  // 3. Points take their cell's covariance; sparse cells use k nearest neighbours.
  ParallelRanges(points.size(), num_threads, 0, [&](size_t begin, size_t end, int&) {
    for (size_t i = begin; i < end; ++i) {
      out[i] = cell_sparse[cell_of[i]] ? KNearestCovariance(points, index, points[i], k)
                                       : cell_cov[cell_of[i]];
    }
  });
  return out;
}

}  // namespace mapdelta::detail

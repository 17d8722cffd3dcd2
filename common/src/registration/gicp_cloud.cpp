// GicpCloud: downsampling, per-point plane-regularized covariances, k-d tree.
#include <cmath>
#include <string>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/gicp_factor.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "parallel.hpp"

namespace mapdelta {
namespace {

void Require(bool ok, const std::string& field, const std::string& expectation) {
  if (!ok) {
    throw Error(ErrorCode::kInvalidArgument, "GicpParams." + field + " " + expectation);
  }
}

// Covariance of the k nearest neighbours of `query` (itself included), plane-regularized.
// Too few or coincident neighbours carry no shape: an isotropic unit covariance then.
Eigen::Matrix3f PointCovariance(const NeighborIndex& index, const PointCloud& points,
                                const Point& query, size_t k) {
  const std::vector<size_t> neighbors = index.KNearest(query, k);
  if (neighbors.size() < 5) return Eigen::Matrix3f::Identity();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i : neighbors) mean += points[i].cast<double>();
  mean /= static_cast<double>(neighbors.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t i : neighbors) {
    const Eigen::Vector3d d = points[i].cast<double>() - mean;
    cov += d * d.transpose();
  }
  cov /= static_cast<double>(neighbors.size());
  if (!(cov.trace() > 1e-12) || !cov.allFinite()) return Eigen::Matrix3f::Identity();
  return RegularizePlaneCovariance(cov).cast<float>();
}

}  // namespace

void ValidateGicpParams(const GicpParams& p) {
  Require(p.max_iterations >= 1, "max_iterations", "must be >= 1");
  Require(std::isfinite(p.max_correspondence_m) && p.max_correspondence_m > 0,
          "max_correspondence_m", "must be finite and > 0");
  Require(p.k_neighbors >= 5, "k_neighbors", "must be >= 5");
  Require(std::isfinite(p.voxel_m) && p.voxel_m >= 0, "voxel_m", "must be finite and >= 0");
  Require(std::isfinite(p.rotation_eps_rad) && p.rotation_eps_rad > 0, "rotation_eps_rad",
          "must be finite and > 0");
  Require(std::isfinite(p.translation_eps_m) && p.translation_eps_m > 0, "translation_eps_m",
          "must be finite and > 0");
  Require(p.num_threads >= 1, "num_threads", "must be >= 1");
  Require(std::isfinite(p.covariance_scale) && p.covariance_scale > 0, "covariance_scale",
          "must be finite and > 0");
}

struct GicpCloud::Impl {
  PointCloud points;  // declared before index: the index references it
  NeighborIndex index;
  std::vector<Eigen::Matrix3f> covariances;
  explicit Impl(PointCloud cloud) : points(std::move(cloud)), index(points) {}
};

GicpCloud::GicpCloud(const PointCloud& cloud, const GicpParams& params) {
  ValidateGicpParams(params);
  PointCloud points;
  if (params.voxel_m > 0) {
    points = VoxelDownsample(cloud, static_cast<float>(params.voxel_m));  // skips non-finite
  } else {
    points = cloud;
    RemoveNonFinite(&points);
  }
  impl_ = std::make_unique<Impl>(std::move(points));
  const PointCloud& pts = impl_->points;
  impl_->covariances.resize(pts.size());
  const size_t k = static_cast<size_t>(params.k_neighbors);
  detail::ParallelRanges(pts.size(), params.num_threads, 0,
                         [&](size_t begin, size_t end, int&) {
                           for (size_t i = begin; i < end; ++i) {
                             impl_->covariances[i] = PointCovariance(impl_->index, pts, pts[i], k);
                           }
                         });
}

GicpCloud::~GicpCloud() = default;
GicpCloud::GicpCloud(GicpCloud&&) noexcept = default;
GicpCloud& GicpCloud::operator=(GicpCloud&&) noexcept = default;

size_t GicpCloud::size() const { return impl_->points.size(); }
const PointCloud& GicpCloud::points() const { return impl_->points; }
const std::vector<Eigen::Matrix3f>& GicpCloud::covariances() const { return impl_->covariances; }
bool GicpCloud::Nearest(const Point& query, size_t* index, float* distance) const {
  return impl_->index.Nearest(query, index, distance);
}

}  // namespace mapdelta

// GicpCloud: downsampling, per-point plane-regularized covariances, k-d tree.
#include <cmath>
#include <limits>
#include <mutex>
#include <string>

#include "covariance_estimation.hpp"
#include "gicp_cloud_access.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/gicp_factor.hpp"
#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta {
namespace {

void Require(bool ok, const std::string& field, const std::string& expectation) {
  if (!ok) {
    throw Error(ErrorCode::kInvalidArgument, "GicpParams." + field + " " + expectation);
  }
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
  PointCloud points;
  // Plane covariances are I - (1 - 1e-3) n n^T: AlignGicp works with the normals (its
  // weights in closed form from them).
  std::vector<Eigen::Vector3f> normals;
  explicit Impl(PointCloud cloud) : points(std::move(cloud)) {}

  // Built on first use: 0.15 ms for 6k points, which a source cloud whose covariances come
  // from voxel blocks never needs.
  const detail::KdTree& Tree() const {
    std::call_once(tree_built_, [this] { tree_ = detail::KdTree(points); });
    return tree_;
  }

  // The 3x3 matrices, only for callers of covariances() (~0.06 ms per 6k points).
  const std::vector<Eigen::Matrix3f>& Covariances() const {
    std::call_once(covariances_built_, [this] {
      covariances_.resize(normals.size());
      for (size_t i = 0; i < normals.size(); ++i) {
        covariances_[i] = PlaneCovariance(normals[i].cast<double>()).cast<float>();
      }
    });
    return covariances_;
  }

 private:
  mutable std::once_flag tree_built_, covariances_built_;
  mutable detail::KdTree tree_;
  mutable std::vector<Eigen::Matrix3f> covariances_;
};

namespace detail {
const KdTree& GicpCloudAccess::Tree(const GicpCloud& cloud) { return cloud.impl_->Tree(); }
const std::vector<Eigen::Vector3f>& GicpCloudAccess::Normals(const GicpCloud& cloud) {
  return cloud.impl_->normals;
}
}  // namespace detail

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
  const size_t k = static_cast<size_t>(params.k_neighbors);
  if (params.covariance_neighborhood == CovarianceNeighborhood::kVoxelBlock && params.voxel_m > 0) {
    impl_->normals = detail::NormalsVoxelBlock(
        impl_->points, kVoxelBlockCellFactor * params.voxel_m, params.num_threads);
  } else {
    impl_->normals = detail::NormalsKNearest(impl_->points, impl_->Tree(), k, params.num_threads);
  }
}

GicpCloud::~GicpCloud() = default;
GicpCloud::GicpCloud(GicpCloud&&) noexcept = default;
GicpCloud& GicpCloud::operator=(GicpCloud&&) noexcept = default;

size_t GicpCloud::size() const { return impl_->points.size(); }
const PointCloud& GicpCloud::points() const { return impl_->points; }
const std::vector<Eigen::Matrix3f>& GicpCloud::covariances() const { return impl_->Covariances(); }
bool GicpCloud::Nearest(const Point& query, size_t* index, float* distance) const {
  return impl_->Tree().NearestWithin(query, std::numeric_limits<float>::infinity(), index,
                                     distance);
}

bool GicpCloud::NearestWithin(const Point& query, float max_distance, size_t* index,
                              float* distance) const {
  return impl_->Tree().NearestWithin(query, max_distance, index, distance);
}

}  // namespace mapdelta

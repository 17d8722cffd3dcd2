#pragma once
// Generalized ICP (Segal et al., RSS 2009) with plane-regularized per-point covariances
// (as fast_gicp / small_gicp), k-d tree correspondences, Levenberg-Marquardt on SE(3), and a
// full 6x6 pose covariance at the solution. Multi-threaded with std::thread (num_threads per
// call; nothing process-wide is changed).
//
// Tangent order of H, b and covariance: [rotation(3), translation(3)], perturbation on the
// right: T_target_source * Exp(delta), with Exp(delta) = (ExpSO3(delta.head<3>()),
// delta.tail<3>()) (docs/conventions.md). See registration/se3_tangent.hpp.
//
// "Did not converge" is a result, not an exception. Exceptions (mapdelta::Error,
// kInvalidArgument) only for bad parameters or a non-finite initial guess.
#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta {
namespace detail {
struct GicpCloudAccess;  // AlignGicp's access to the search structures (gicp_cloud_access.hpp)
}  // namespace detail

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Which points shape each point's covariance.
enum class CovarianceNeighborhood {
  kKNearest,  // the k_neighbors nearest points (k-d tree): exact, ~2 us per point
  // The points in the 3x3x3 voxel cells (edge kVoxelBlockCellFactor * voxel_m) around the
  // point's cell; ~20x cheaper; a block of fewer than 6 points has no usable shape and gets
  // the isotropic unit covariance (as a shapeless k-nearest neighbourhood does). Needs
  // voxel_m > 0 (the cell follows the point spacing), else kKNearest is used.
  kVoxelBlock,
};
// Cell edge / voxel_m for kVoxelBlock: a 3-cell block then spans ~5 voxels, about the extent
// of 20 nearest neighbours on a surface sampled at voxel_m.
inline constexpr double kVoxelBlockCellFactor = 2.0;

struct GicpParams {
  int max_iterations = 64;            // outer (linearization) iterations
  double max_correspondence_m = 2.0;  // source points farther from the target are outliers
  int k_neighbors = 20;               // neighbours for each point's covariance (>= 5; kKNearest)
  CovarianceNeighborhood covariance_neighborhood = CovarianceNeighborhood::kVoxelBlock;
  double voxel_m = 0.0;             // > 0: voxel-downsample source and target first
  double rotation_eps_rad = 1e-4;   // converged when a step rotates less than this ...
  double translation_eps_m = 1e-4;  // ... and translates less than this
  int num_threads = 2;              // threads for covariances and linearization
  // Multiplies the statistically estimated covariance (see RegistrationResult::covariance).
  // 1.0 is calibrated for independent per-point noise; callers whose clouds carry
  // correlated errors (stereo depth bias, odometry drift inside a local cloud) inflate it.
  double covariance_scale = 1.0;
  // Source points as exact points against the target's planes (point-to-plane) instead of
  // with their own plane covariances: for sparse sources, whose neighbourhoods span several
  // surfaces and give normals that cancel the target's.
  bool source_as_points = false;
};

// Throws Error(kInvalidArgument) naming the first bad field.
void ValidateGicpParams(const GicpParams& params);

struct RegistrationResult {
  SE3 T_target_source = SE3::Identity();
  bool converged = false;
  int iterations = 0;
  size_t num_inliers = 0;  // source points with a target neighbour within max_correspondence_m
  size_t num_source_points = 0;  // source points used (after downsampling / non-finite removal)
  // Gauss-Newton system at the solution: H = sum J^T W J, b = sum J^T W r (right perturbation).
  Matrix6d H = Matrix6d::Zero();
  Vector6d b = Vector6d::Zero();
  double error = 0;      // sum of r^T W r over inliers at the solution
  double fitness_m = 0;  // mean nearest-neighbour distance of inliers at the solution, metres
  // Full 6x6 covariance of the estimate, rad^2 / m^2, [rotation, translation]. Computed as the
  // sandwich (robust) form H^-1 (sum g_i g_i^T) H^-1 * N/(N-6), g_i = J_i^T W_i r_i: the
  // inverse Hessian scaled by the observed residuals, point by point. This is the inverse
  // Hessian times the residual variance when the GICP weights match the noise, and stays
  // calibrated when they do not (plane-regularized weights are unitless by design). Then
  // multiplied by GicpParams::covariance_scale. Degenerate directions get a huge variance.
  Matrix6d covariance = Matrix6d::Identity();
  Eigen::Vector3d source_centroid = Eigen::Vector3d::Zero();  // in the source frame
};

// A cloud prepared for GICP: optionally voxel-downsampled, non-finite points dropped,
// per-point plane-regularized covariances and a k-d tree (built on first use: a source cloud
// whose covariances come from voxel blocks never needs one). Build a target once and align
// many sources to it (a prior-map tile, a session cloud). Movable; immutable after
// construction and safe to share between threads.
class GicpCloud {
 public:
  // Uses params.voxel_m, k_neighbors, num_threads. Clouds smaller than k_neighbors use all points.
  GicpCloud(const PointCloud& cloud, const GicpParams& params);
  ~GicpCloud();
  GicpCloud(GicpCloud&&) noexcept;
  GicpCloud& operator=(GicpCloud&&) noexcept;

  size_t size() const;
  const PointCloud& points() const;
  // Unit-scale covariances: eigenvalues (1e-3, 1, 1) along (normal, tangent, tangent), or the
  // identity where the neighbourhood has no shape (built on the first call).
  const std::vector<Eigen::Matrix3f>& covariances() const;
  // Nearest point index and Euclidean distance; false if the cloud is empty.
  bool Nearest(const Point& query, size_t* index, float* distance) const;
  // Nearest point strictly closer than max_distance (a bound that prunes the search).
  bool NearestWithin(const Point& query, float max_distance, size_t* index, float* distance) const;

 private:
  friend struct detail::GicpCloudAccess;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

RegistrationResult AlignGicp(const GicpCloud& target, const GicpCloud& source,
                             const SE3& init_T_target_source, const GicpParams& params);
RegistrationResult AlignGicp(const GicpCloud& target, const PointCloud& source,
                             const SE3& init_T_target_source, const GicpParams& params);
RegistrationResult AlignGicp(const PointCloud& target, const PointCloud& source,
                             const SE3& init_T_target_source, const GicpParams& params);

}  // namespace mapdelta

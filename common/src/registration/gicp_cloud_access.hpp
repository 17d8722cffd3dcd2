#pragma once
// AlignGicp's view of a GicpCloud's search structure (defined in gicp_cloud.cpp).
#include <Eigen/Core>
#include <vector>

#include "kd_tree.hpp"
#include "mapdelta/common/registration/gicp.hpp"

namespace mapdelta::detail {

struct GicpCloudAccess {
  // The cloud's k-d tree, built on the first call (thread-safe).
  static const KdTree& Tree(const GicpCloud& cloud);
  // Per point: the plane normal of its covariance (zero for the identity).
  static const std::vector<Eigen::Vector3f>& Normals(const GicpCloud& cloud);
};

}  // namespace mapdelta::detail

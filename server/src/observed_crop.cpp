#include "observed_crop.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <sstream>

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {

std::string CropOctreeXY(const std::string& octree_bt, double min_x, double min_y, double max_x,
                         double max_y) {
  std::istringstream in(octree_bt);
  octomap::OcTree tree(0.1);
  if (!tree.readBinary(in))
    throw Error(ErrorCode::kParse, "observed octree: not an OctoMap binary tree");
  const double res = tree.getResolution();
  octomap::OcTree out(res);
  // Voxel (ix, iy) covers [ix * res, (ix + 1) * res) in x (OctoMap keys are ix + 2^15), so
  // overlap is decided on integer indices; a voxel that only touches the box (tile edges are
  // often voxel edges) does not overlap it. The tolerance absorbs rounding of ix * res.
  const double eps = 1e-6 * res;
  const auto overlaps = [&](int64_t ix, int64_t iy) {
    return (ix + 1) * res > min_x + eps && ix * res < max_x - eps && (iy + 1) * res > min_y + eps &&
           iy * res < max_y - eps;
  };
  const int64_t offset = int64_t{1} << (tree.getTreeDepth() - 1);
  // Only leaves near the box: OctoMap's bounding-box iterator, z over the whole key range.
  // Its corners must lie inside the key range (else OctoMap's iterator is invalid).
  const double reach = res * static_cast<double>(offset - 1);
  const auto inside = [reach](double v) {
    return static_cast<float>(std::clamp(v, -reach, reach));
  };
  const octomap::point3d lo(inside(min_x), inside(min_y), inside(-reach));
  const octomap::point3d hi(inside(max_x), inside(max_y), inside(reach));
  const unsigned max_depth = tree.getTreeDepth();
  for (auto it = tree.begin_leafs_bbx(lo, hi), end = tree.end_leafs_bbx(); it != end; ++it) {
    const float log_odds = it->getLogOdds();
    // A leaf above the finest depth stands for a cube of n^3 identical voxels (pruned).
    const int64_t n = int64_t{1} << (max_depth - it.getDepth());
    const octomap::point3d c = it.getCoordinate();
    const double half = it.getSize() / 2;
    const int64_t ix0 = std::llround((c.x() - half) / res),
                  iy0 = std::llround((c.y() - half) / res);
    const int64_t iz0 = std::llround((c.z() - half) / res);
    for (int64_t i = 0; i < n; ++i) {
      for (int64_t j = 0; j < n; ++j) {
        if (!overlaps(ix0 + i, iy0 + j)) continue;
        for (int64_t k = 0; k < n; ++k) {
          const octomap::OcTreeKey key(static_cast<octomap::key_type>(ix0 + i + offset),
                                       static_cast<octomap::key_type>(iy0 + j + offset),
                                       static_cast<octomap::key_type>(iz0 + k + offset));
          out.setNodeValue(key, log_odds, true);
        }
      }
    }
  }
  out.updateInnerOccupancy();
  out.prune();
  std::ostringstream os;
  if (!out.writeBinaryConst(os))
    throw Error(ErrorCode::kInternal, "observed octree: binary write failed");
  return os.str();
}

}  // namespace mapdelta::server

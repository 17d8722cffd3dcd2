#include "voxel_consensus.hpp"

#include <algorithm>
#include <limits>
#include <set>

#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/parallel.hpp"

namespace mapdelta::server {

std::vector<char> VoxelsWithConsensus(const std::vector<const AggregateVoxel*>& voxels,
                                      const PointCloud& centroids,
                                      const std::vector<int64_t>& sessions,
                                      const SessionObserves& observes, double reach_m,
                                      int threads) {
  const NeighborIndex index(centroids);
  std::vector<char> keep(voxels.size(), 1);
  ParallelFor(
      voxels.size(), threads,
      [&](size_t i) {
        const AggregateVoxel& v = *voxels[i];
        const auto filled = [&](int64_t s) {
          return std::binary_search(v.sessions.begin(), v.sessions.end(), s);
        };
        std::set<int64_t> beside;  // sessions that filled a voxel within reach
        if (reach_m > 0) {
          for (size_t j : index.RadiusSearch(v.centroid, static_cast<float>(reach_m)))
            beside.insert(voxels[j]->sessions.begin(), voxels[j]->sessions.end());
        }
        size_t there_not_filled = 0;
        int64_t newest_not_filled = std::numeric_limits<int64_t>::min();
        for (int64_t s : sessions) {
          if (!filled(s) && (beside.count(s) || observes(s, v.centroid))) {
            ++there_not_filled;
            newest_not_filled = std::max(newest_not_filled, s);
          }
        }
        const size_t filled_by = v.sessions.size();
        keep[i] =
            there_not_filled < filled_by || (there_not_filled == filled_by && !v.sessions.empty() &&
                                             v.sessions.back() > newest_not_filled);
      },
      /*grain=*/1024);
  return keep;
}

}  // namespace mapdelta::server

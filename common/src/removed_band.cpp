#include "mapdelta/common/removed_band.hpp"

#include <cmath>
#include <vector>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/parallel.hpp"

namespace mapdelta {

PointCloud RemovedBand(const PointCloud& observed_prior, const PointCloud& global,
                       double clear_radius_m, double th_ch_m, int threads) {
  if (!(std::isfinite(th_ch_m) && clear_radius_m >= 0 && clear_radius_m <= th_ch_m)) {
    throw Error(ErrorCode::kInvalidArgument,
                "removed band: the clear radius must be in [0, th_ch]");
  }
  if (clear_radius_m == 0 || global.empty()) return {};
  const NeighborIndex index(global);
  std::vector<char> in_band(observed_prior.size(), 0);
  const auto clear = static_cast<float>(clear_radius_m), th_ch = static_cast<float>(th_ch_m);
  ParallelFor(
      observed_prior.size(), threads,
      [&](size_t i) {
        const Point& p = observed_prior[i];
        in_band[i] = index.AnyWithin(p, th_ch, /*inclusive=*/false) &&
                     !index.AnyWithin(p, clear, /*inclusive=*/false);
      },
      2048);
  PointCloud out;
  for (size_t i = 0; i < observed_prior.size(); ++i) {
    if (in_band[i]) out.push_back(observed_prior[i]);
  }
  return out;
}

std::vector<size_t> GrowFrom(const PointCloud& strong, const PointCloud& weak, double radius_m) {
  if (strong.empty() || weak.empty() || !(radius_m > 0)) return {};
  const NeighborIndex weak_index(weak);
  const auto radius = static_cast<float>(radius_m);
  std::vector<char> reached(weak.size(), 0);
  std::vector<size_t> frontier;
  const auto visit = [&](const Point& p) {
    for (size_t j : weak_index.RadiusSearch(p, radius)) {
      if (!reached[j]) {
        reached[j] = 1;
        frontier.push_back(j);
      }
    }
  };
  for (const Point& p : strong) visit(p);
  while (!frontier.empty()) {
    const size_t j = frontier.back();
    frontier.pop_back();
    visit(weak[j]);
  }
  std::vector<size_t> out;
  for (size_t j = 0; j < weak.size(); ++j) {
    if (reached[j]) out.push_back(j);
  }
  return out;
}

}  // namespace mapdelta

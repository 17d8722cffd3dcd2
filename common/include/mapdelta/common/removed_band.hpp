#pragma once
// Removed points near the surfaces a session did see (issue 21): the band of prior points that
// Alg. 2's th_ch masks although no current point lies close to them, and the growth that ties
// such points to a removal with full evidence.
#include <cstddef>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

// The points of `observed_prior` whose nearest point of `global` is at least clear_radius_m
// away but nearer than th_ch_m: Alg. 2 never reports them, though nothing was seen there.
// Empty when clear_radius_m is 0. Throws Error(kInvalidArgument) unless 0 <= clear <= th_ch.
PointCloud RemovedBand(const PointCloud& observed_prior, const PointCloud& global,
                       double clear_radius_m, double th_ch_m, int threads);

// The indices (ascending) of the points of `weak` linked to some point of `strong` by a chain
// of points of `weak`, each within radius_m of the one before (hysteresis, as Canny's edges).
// Empty when radius_m <= 0.
std::vector<size_t> GrowFrom(const PointCloud& strong, const PointCloud& weak, double radius_m);

}  // namespace mapdelta

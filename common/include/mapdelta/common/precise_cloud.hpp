#pragma once
// Clouds in double, as read from georeferenced files before the server makes them relative to
// its map's origin: float32 rounds a UTM northing (5.4e6 m) to 0.5 m, double keeps nanometres
// there. A header of its own so that the widely included point_cloud.hpp stays as it is.
#include <Eigen/Core>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

using PrecisePoint = Eigen::Vector3d;
using PrecisePointCloud = std::vector<PrecisePoint>;

// Drops points with non-finite coordinates; returns how many were dropped.
size_t RemoveNonFinite(PrecisePointCloud* cloud);
// Each coordinate rounded to float32 (millimetre-exact only near the origin).
PointCloud ToFloat(const PrecisePointCloud& cloud);
// An origin for float32 local coordinates of `cloud` (local = point - origin): per axis 0 if
// every coordinate is within bound_m of 0 (a local map keeps its coordinates), else the middle
// of the cloud's extent rounded down to a multiple of step_m (x, y) or of 1 m (z), so that a
// cloud up to 2 x bound_m wide fits and the same cloud always gets the same origin.
Eigen::Vector3d ChooseLocalOrigin(const PrecisePointCloud& cloud, double bound_m, double step_m);

}  // namespace mapdelta

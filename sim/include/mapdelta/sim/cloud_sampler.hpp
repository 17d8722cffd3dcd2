#pragma once
// Ground-truth clouds, LiDAR-like: every exposed surface (ground within the scene extent, box
// faces not buried in other boxes) sampled on a grid at leaf/2, then voxel-downsampled to leaf.
#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/sim/scene.hpp"

namespace mapdelta::sim {

PointCloud SampleSceneCloud(const Scene& scene, double leaf_m);
// Only the given object's exposed surfaces (others in `scene` still hide its buried faces).
PointCloud SampleObjectCloud(const Scene& scene, const Object& object, double leaf_m);

}  // namespace mapdelta::sim

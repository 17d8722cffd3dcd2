#pragma once
// Back-projection of a depth image to a cloud: pixel (u, v) with depth z (along the optical
// axis) becomes T_frame_cam * camera.BackProject(u, v, z). Integer pixel coordinates, as
// PinholeCamera::Project/BackProject.
#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

// Every valid depth (finite, > 0, < max_depth_m) of every stride-th pixel in u and v.
// Throws Error(kInvalidArgument) if the image size differs from the camera's or stride < 1.
PointCloud DepthToCloud(const PinholeCamera& camera, const DepthImage& depth,
                        const SE3& T_frame_cam, double max_depth_m, int stride = 1);

}  // namespace mapdelta

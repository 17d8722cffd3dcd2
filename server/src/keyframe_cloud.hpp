#pragma once
// One keyframe's contribution to its session cloud: depth < th_d of every pixel_stride-th
// pixel, back-projected with the uploaded T_map_cam and voxel-filtered. Computed at upload
// (the upload decodes the PNG anyway to validate it) and stored beside the keyframe, so that
// a commit's first pass needs no PNG decode; recomputed from the PNG when the stored one is
// missing or was made with other parameters.
#include <string>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/common/pose.hpp"
#include "mapdelta/server/config.hpp"

namespace mapdelta::server {

PointCloud KeyframeCloud(const PinholeCamera& camera, const SE3& T_map_cam, const DepthImage& depth,
                         const PipelineConfig& pipeline);

// The parameters KeyframeCloud depends on (besides the session's camera and depth scale,
// which a session never changes), as a string stored with the cloud.
std::string KeyframeCloudParams(const PipelineConfig& pipeline);

}  // namespace mapdelta::server

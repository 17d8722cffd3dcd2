#pragma once
// The keyframe folder: what a vehicle produces and the server or mapdelta-detect consumes.
//   DIR/camera.yaml      intrinsics of the depth images (width, height, fx, fy, cx, cy,
//   depth_scale) DIR/poses.txt        TUM lines, one per keyframe: T_map_cam (camera pose in the
//   map frame) DIR/covariances.txt  optional: "t_ns c00 c01 ... c55" (6x6 row-major, order [rx ry
//   rz tx ty tz]) DIR/depth/<t_ns>.png 16-bit depth, depth_scale units per metre, 0 = none
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct Keyframe {
  int64_t t_ns = 0;
  SE3 T_map_cam = SE3::Identity();
  std::optional<Matrix6d> covariance;  // of T_map_cam, tangent order [rotation, translation]
  DepthImage depth;
};

struct KeyframeFolder {
  PinholeCamera camera;
  double depth_scale = kDefaultDepthScale;
  std::vector<Keyframe> keyframes;
};

// Throws Error naming the file and the problem (missing file, bad line, image size mismatch).
KeyframeFolder ReadKeyframeFolder(const std::string& dir);
// The same without the depth images (each Keyframe::depth left empty), for streaming long
// sessions: load each depth with ReadKeyframeDepth when it is needed.
KeyframeFolder ReadKeyframeFolderIndex(const std::string& dir);
DepthImage ReadKeyframeDepth(const std::string& dir, const KeyframeFolder& folder, int64_t t_ns);
void WriteKeyframeFolder(const std::string& dir, const KeyframeFolder& folder);
// Appends one keyframe to an existing folder (camera.yaml written on first call).
void AppendKeyframe(const std::string& dir, const PinholeCamera& camera, double depth_scale,
                    const Keyframe& keyframe);

}  // namespace mapdelta

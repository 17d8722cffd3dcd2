#pragma once
// Stereo + IMU initialization without assuming rest.
//   1. chain frame-to-frame motion from stereo: triangulate the previous frame's stereo
//      features (metric, the baseline fixes the scale), PnP-RANSAC them in the new frame;
//   2. once `init_frames` frames spanning `init_min_span_s` are chained: gyro bias from
//      visual vs preintegrated rotation;
//   3. velocities and gravity (in the first body frame) by linear least squares over the
//      preintegrated velocity and position deltas; accept if |g| is plausible;
//   4. rotate everything so that gravity points along -z (yaw of the first frame kept).
#include <deque>
#include <optional>
#include <vector>

#include "mapdelta/vio/geometry.hpp"
#include "mapdelta/vio/imu_preintegration.hpp"
#include "mapdelta/vio/types.hpp"

namespace mapdelta::vio {

struct InitFrame {
  FrameFeatures features;
  ImuPreintegration pre;  // from the previous frame to this one (empty for the first)
  NavState state;
};

class Initializer {
 public:
  Initializer(const VioConfig& config, const StereoExtrinsics& extrinsics);
  // Adds a frame; returns the initialized frames (oldest first) once initialization succeeds.
  std::optional<std::vector<InitFrame>> AddFrame(const FrameFeatures& features,
                                                 const ImuPreintegration& pre);
  void Reset() { frames_.clear(); }
  int buffered() const { return static_cast<int>(frames_.size()); }

 private:
  bool RelativeMotion(const FrameFeatures& prev, const FrameFeatures& cur, SE3* T_prev_cur) const;
  bool Align(std::vector<InitFrame>* frames) const;

  VioConfig config_;
  StereoExtrinsics ext_;
  std::deque<InitFrame> frames_;
};

}  // namespace mapdelta::vio

#pragma once
// Stereo + IMU initialization without assuming rest.
//   1. chain the motion from stereo: triangulate an anchor frame's stereo features (metric,
//      the baseline fixes the scale) and PnP-RANSAC them in the new frame. The anchor is the
//      oldest buffered frame that still shares enough features, not the previous frame:
//      frame-to-frame PnP at 30 Hz chained ~27 small, noisy motions whose rotation drift the
//      gyro-bias and gravity fits then absorbed (paper preset, noiseless: 6.4 deg tilt and a
//      0.034 rad/s gyro bias at initialization; the longer the window, the worse);
//   2. once `init_frames` frames spanning `init_min_span_s` are chained: gyro bias from
//      visual vs preintegrated rotation;
//   3. velocities and gravity (in the first body frame) by linear least squares over the
//      preintegrated velocity and position deltas; accept if |g| is plausible;
//   4. rotate everything so that gravity points along -z (yaw of the first frame kept).
// Beside it, at rest (StaticInitConfig): once the newest frames span `window_s` and their IMU
// samples look like rest (rest_detector.hpp) while the PnP chain of step 1 says they did not
// move, they initialize at once with zero velocity, the mean gyro reading as the gyro bias and
// gravity opposite to the mean accelerometer reading (the moving alignment needs
// init_min_span_s of motion and would wait 0.9 s).
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
  void Reset() {
    frames_.clear();
    anchor_ = 0;
  }
  int buffered() const { return static_cast<int>(frames_.size()); }

 private:
  // PnP of prev's stereo points in cur; fails with fewer than `min_inliers` RANSAC inliers.
  bool RelativeMotion(const FrameFeatures& prev, const FrameFeatures& cur, SE3* T_prev_cur,
                      size_t min_inliers = 10) const;
  bool Align(std::vector<InitFrame>* frames) const;
  // The newest frames spanning StaticInitConfig::window_s, initialized at rest; nothing if the
  // IMU or the PnP chain says they moved.
  std::optional<std::vector<InitFrame>> StartAtRest() const;

  VioConfig config_;
  StereoExtrinsics ext_;
  std::deque<InitFrame> frames_;
  size_t anchor_ = 0;  // index in frames_ of the frame new frames are PnP-ed against
};

}  // namespace mapdelta::vio

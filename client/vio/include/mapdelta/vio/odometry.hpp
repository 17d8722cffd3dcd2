#pragma once
// Public API of the stereo-inertial odometry (no OpenCV or Ceres in this header).
//
//   StereoInertialOdometry vio(config, seq.cam0, seq.cam1, seq.imu);
//   for each IMU sample up to (and one past) the frame time: vio.AddImu(sample);
//   FrameEstimate e = vio.AddStereoFrame(t_ns, left_view, right_view);
//   if (e.initialized) use e.T_world_body;  // odometry world: z up, gravity -z
//
// Images are 8-bit grey as the cameras deliver them; the cameras' T_BS (sensor.yaml) define
// T_body_cam. A pair that is not already rectified (radial-tangential distortion, cameras not
// parallel: real EuRoC) is rectified internally (stereo_rectifier.hpp) before the front end. Poses
// are of the body frame of the sequence (the IMU's T_BS is honoured). The odometry world's origin
// and yaw are those of the body when initialization succeeded.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/pose.hpp"
#include "mapdelta/vio/types.hpp"

namespace mapdelta::vio {

struct GrayImageView {
  int width = 0;
  int height = 0;
  int stride_bytes = 0;
  const uint8_t* data = nullptr;
};

// Wall-clock milliseconds per stage.
struct StageTimes {
  double frontend_ms = 0;        // KLT, corner detection, stereo matching
  double initialization_ms = 0;  // stereo PnP chain + IMU alignment
  double optimization_ms = 0;    // window solve + outlier removal
  double marginalization_ms = 0;
  double covariance_ms = 0;  // keyframe relative-motion covariance
  double total_ms = 0;
  StageTimes& operator+=(const StageTimes& o);
};

struct FrameEstimate {
  int64_t t_ns = 0;
  bool initialized = false;  // false: no pose yet (initializing or just reset)
  bool reset = false;        // failure detected at this frame; the estimator restarted
  bool keyframe = false;
  SE3 T_world_body = SE3::Identity();
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero(), accel_bias = Eigen::Vector3d::Zero();
  int landmarks = 0;  // landmarks constraining this frame
  int features = 0;   // front-end features in this frame
  // Keyframes: covariance of T_prevkeyframe_keyframe (body), tangent [rotation, translation],
  // right perturbation (docs/conventions.md). Unset for the first keyframe after a (re)start.
  std::optional<Eigen::Matrix<double, 6, 6>> relative_covariance;
  StageTimes times;
};

// The front end's output for one frame (TrackFrame), input of AddTrackedFrame.
struct TrackedFrame {
  FrameFeatures features;  // normalized image coordinates of the (rectified) cameras
  double frontend_ms = 0;
};

struct KeyframeEstimate {
  int64_t t_ns = 0;
  SE3 T_world_body = SE3::Identity();
  std::optional<Eigen::Matrix<double, 6, 6>> relative_covariance;  // as in FrameEstimate
};

class StereoInertialOdometry {
 public:
  // Throws Error(kUnsupported) for pairs it cannot rectify (distortion models other than
  // radial-tangential, cam1 not beside cam0).
  StereoInertialOdometry(const VioConfig& config, const EurocCamera& cam0, const EurocCamera& cam1,
                         const EurocImu& imu);
  ~StereoInertialOdometry();
  StereoInertialOdometry(const StereoInertialOdometry&) = delete;
  StereoInertialOdometry& operator=(const StereoInertialOdometry&) = delete;

  void AddImu(const ImuSample& sample);
  // Front end then estimator: AddTrackedFrame(TrackFrame(t_ns, left, right)).
  FrameEstimate AddStereoFrame(int64_t t_ns, const GrayImageView& left, const GrayImageView& right);
  // The two halves of AddStereoFrame, for callers that pipeline them: TrackFrame (feature
  // tracking, frame-local) may run on another thread, for a later frame, while AddImu /
  // AddTrackedFrame run for an earlier one. Each half is called in frame order and is not
  // concurrent with itself; every tracked frame must be added, in the same order.
  TrackedFrame TrackFrame(int64_t t_ns, const GrayImageView& left, const GrayImageView& right);
  FrameEstimate AddTrackedFrame(const TrackedFrame& frame);
  // Keyframes whose window optimization is over (final estimates), oldest first.
  std::vector<KeyframeEstimate> TakeFinalizedKeyframes();
  // End of input: finalizes the keyframes still in the window.
  void Finish();
  const StageTimes& accumulated_times() const;
  int frames() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mapdelta::vio

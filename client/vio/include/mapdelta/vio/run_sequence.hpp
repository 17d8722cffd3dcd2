#pragma once
// Runs the odometry over an EuRoC-layout sequence (images read from disk, IMU fed in time
// order). Used by the CLI, the accuracy test and the benchmark.
#include <functional>
#include <optional>
#include <vector>

#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/pose.hpp"
#include "mapdelta/vio/odometry.hpp"

namespace mapdelta::vio {

struct SequenceRunOptions {
  int max_frames = 0;  // 0: all
  // Decode and track (front end) on a second thread, up to a few frames ahead of the
  // estimator: the same estimates (TrackFrame / AddTrackedFrame), less wall time.
  bool pipelined = false;
  // Called after every frame (progress reporting); may be empty.
  std::function<void(int frame, int total, const FrameEstimate&)> on_frame;
};

struct SequenceRunResult {
  Trajectory frames;     // T_world_body of every initialized frame (causal estimates)
  Trajectory keyframes;  // T_world_body of keyframes, final window estimates
  std::vector<std::optional<Eigen::Matrix<double, 6, 6>>> keyframe_covariances;
  StageTimes times;  // summed over frames
  int processed = 0, initialized = 0, resets = 0;
  std::vector<int64_t> reset_t_ns;  // frame times at which a failure reset the estimator
  double sequence_duration_s = 0;
};

// Throws Error (kIo) if an image cannot be read.
SequenceRunResult RunSequence(const EurocSequence& sequence, const VioConfig& config,
                              const SequenceRunOptions& options = {});

}  // namespace mapdelta::vio

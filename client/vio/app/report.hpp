#pragma once
// Accuracy report of a VIO run against ground truth, for the mapdelta-vio CLI: ATE per
// tracking segment (a reset starts a new odometry world, so one alignment over the whole run
// would blame the estimator for the re-anchoring) and per-frame attitude errors.
#include <cstdint>
#include <string>
#include <vector>

#include "mapdelta/common/pose.hpp"

namespace mapdelta::vio {

struct SegmentAte {
  int64_t t_begin_ns = 0, t_end_ns = 0;
  size_t pairs = 0;
  double rmse = 0, max = 0;  // metres, SE(3)-aligned within the segment
};

// Splits `estimate` at the reset times (each reset ends a segment) and aligns each segment
// with at least 3 ground-truth pairs on its own.
std::vector<SegmentAte> AtePerSegment(const Trajectory& ground_truth, const Trajectory& estimate,
                                      const std::vector<int64_t>& reset_t_ns);

// Writes "t_s roll_err pitch_err yaw_err tilt_err" (degrees) per estimated frame. Roll and
// pitch are absolute (both worlds have z up); yaw is relative to the first frame of the
// frame's segment (the odometry's yaw origin is arbitrary). Returns the largest tilt error
// within the first `window_s` seconds of any segment and after it, for a one-line summary.
struct AttitudeSummary {
  double max_tilt_early_deg = 0, max_tilt_late_deg = 0;
  double max_yaw_early_deg = 0, max_yaw_late_deg = 0;
};
AttitudeSummary WriteAttitudeErrors(const std::string& path, const Trajectory& ground_truth,
                                    const Trajectory& estimate,
                                    const std::vector<int64_t>& reset_t_ns, double window_s);

}  // namespace mapdelta::vio

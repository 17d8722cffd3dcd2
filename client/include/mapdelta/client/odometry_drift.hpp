#pragma once
// A test fixture for the fusion: odometry made from a ground-truth trajectory by re-chaining
// its relative motions with a drift (yaw and pitch per metre travelled, a scale error) and
// white noise. Expresses the result in its own odometry frame (identity at the first pose).
#include <cstdint>

#include "mapdelta/common/pose.hpp"

namespace mapdelta::client {

struct DriftParams {
  double yaw_deg_per_m = 0.05;
  double pitch_deg_per_m = 0.0;
  double scale_error = 0.01;  // relative translation error
  double rot_noise_deg_per_sqrt_m = 0.0;
  double trans_noise_per_sqrt_m = 0.0;
  uint32_t seed = 1;
};

Trajectory AddDrift(const Trajectory& ground_truth, const DriftParams& params);

}  // namespace mapdelta::client

#pragma once
// Registration attempts against ground truth: the CSV the run command writes and the
// covariance calibration check (issue: per-axis errors within 3 sigma in ~97% of cases).
#include <string>
#include <vector>

#include "mapdelta/client/pipeline.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta::client {

struct CovarianceCalibration {
  size_t registrations = 0;      // accepted registrations with ground truth at their time
  double within_3sigma[6] = {};  // per tangent axis [rx ry rz tx ty tz], fraction of |e| <= 3 sigma
  double within_3sigma_all = 0;  // over all axes
  double mean_nees = 0;          // e^T C^-1 e, expected 6 when calibrated
  double rms_over_sigma[6] = {};  // rms(e_i) / rms(sigma_i): 1 when calibrated, > 1 overconfident
  // Factor on the covariance that would put 97% of the per-axis errors within 3 sigma
  // (from the 97th percentile of |e_i| / sigma_i); 1 means calibrated as is.
  double scale_for_97 = 1.0;
};

// Error e = LocalRight(T_gt, T_registered) (our right-perturbation tangent, as the covariance).
CovarianceCalibration CalibrateAgainst(const std::vector<RegistrationRecord>& records,
                                       const Trajectory& gt);

// CSV: t_ns, keyframe, accepted, fitness_m, inlier_fraction, x y z qx qy qz qw, the 6 sigmas
// (sqrt of the covariance diagonal), reason. Throws Error(kIo) naming the file.
void WriteRegistrationsCsv(const std::string& path, const std::vector<RegistrationRecord>& records);

}  // namespace mapdelta::client

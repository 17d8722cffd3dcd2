#pragma once
// Absolute trajectory error as evo's `evo_ape` computes it (translation part): poses associated
// by timestamp, estimate aligned to the reference by Umeyama (SE(3), Sim(3) or none), then
// statistics of the position errors: rmse, mean, median, std (population), min, max, sse.
#include <cstddef>
#include <string>
#include <vector>

#include "mapdelta/common/pose.hpp"

namespace mapdelta {

enum class AteAlignment { kNone, kSE3, kSim3 };
// "none" / "se3" / "sim3"; false for anything else.
bool ParseAteAlignment(const std::string& text, AteAlignment* alignment);

struct AteParams {
  AteAlignment alignment = AteAlignment::kSE3;
  double max_dt_s = 0.01;  // association tolerance (evo's default)
};

// Index pairs (ref, est). As evo: each stamp of the shorter trajectory is matched to the
// nearest stamp of the longer one (first on ties) if within max_dt_ns.
struct Association {
  std::vector<size_t> ref_index, est_index;
};
Association AssociateByTime(const Trajectory& ref, const Trajectory& est, int64_t max_dt_ns);

// Least-squares similarity target ~ scale * R * source + t (Umeyama, PAMI 1991), columns are
// points. with_scale = false fixes scale to 1. Throws Error(kInvalidArgument) with fewer than
// 3 points or a degenerate (all-equal) source.
struct Similarity {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double scale = 1.0;
};
Similarity Umeyama(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target, bool with_scale);

struct AteResult {
  size_t pairs = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0, sse = 0;
  Similarity alignment;        // applied to the estimate's positions (identity for kNone)
  std::vector<double> errors;  // per pair, metres, in association order
};

// Throws Error(kInvalidArgument) when no pair (or fewer than 3 with alignment) is found.
AteResult ComputeAte(const Trajectory& ref, const Trajectory& est, const AteParams& params = {});

}  // namespace mapdelta

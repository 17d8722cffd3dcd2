#include "mapdelta/common/ate.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "mapdelta/common/error.hpp"

namespace mapdelta {

bool ParseAteAlignment(const std::string& text, AteAlignment* alignment) {
  if (text == "none")
    *alignment = AteAlignment::kNone;
  else if (text == "se3")
    *alignment = AteAlignment::kSE3;
  else if (text == "sim3")
    *alignment = AteAlignment::kSim3;
  else
    return false;
  return true;
}

namespace {

// Seconds as the double evo parses from the text (the nearest double to the decimal stamp):
// stamps near 1.3e9 s have a 2.4e-7 s grid in double, and evo's nearest-stamp choice is made on
// that grid, so matching it pair for pair means comparing the same rounded values.
double Seconds(int64_t t_ns) {
  return static_cast<double>(t_ns / 1000000000) + static_cast<double>(t_ns % 1000000000) * 1e-9;
}

}  // namespace

Association AssociateByTime(const Trajectory& ref, const Trajectory& est, int64_t max_dt_ns) {
  // evo iterates over the shorter trajectory (the first one when equal in length).
  const bool ref_is_short = ref.size() <= est.size();
  const Trajectory& short_traj = ref_is_short ? ref : est;
  const Trajectory& long_traj = ref_is_short ? est : ref;
  const double max_dt = Seconds(max_dt_ns);
  Association out;
  if (long_traj.empty()) return out;
  for (size_t i = 0; i < short_traj.size(); ++i) {
    const double t = Seconds(short_traj[i].t_ns);
    // Stamps are sorted (the readers check it): the nearest is next to the lower bound. Look at
    // a few neighbours in index order and keep the first minimum, as numpy's argmin does.
    const auto it = std::lower_bound(long_traj.begin(), long_traj.end(), short_traj[i].t_ns,
                                     [](const StampedPose& p, int64_t v) { return p.t_ns < v; });
    const size_t center = static_cast<size_t>(it - long_traj.begin());
    size_t first = center >= 2 ? center - 2 : 0;
    while (first > 0 && long_traj[first - 1].t_ns == long_traj[first].t_ns) --first;
    size_t best = first;
    double best_diff = std::abs(Seconds(long_traj[first].t_ns) - t);
    for (size_t j = first + 1; j < std::min(long_traj.size(), center + 2); ++j) {
      const double diff = std::abs(Seconds(long_traj[j].t_ns) - t);
      if (diff < best_diff) {
        best = j;
        best_diff = diff;
      }
    }
    if (best_diff > max_dt) continue;
    out.ref_index.push_back(ref_is_short ? i : best);
    out.est_index.push_back(ref_is_short ? best : i);
  }
  return out;
}

Similarity Umeyama(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                   bool with_scale) {
  const auto n = source.cols();
  if (n < 3 || target.cols() != n) {
    throw Error(ErrorCode::kInvalidArgument, "Umeyama alignment needs at least 3 point pairs");
  }
  // 1. Centroids and the source spread.
  const Eigen::Vector3d mean_s = source.rowwise().mean();
  const Eigen::Vector3d mean_t = target.rowwise().mean();
  const Eigen::Matrix3Xd s = source.colwise() - mean_s;
  const Eigen::Matrix3Xd d = target.colwise() - mean_t;
  const double sigma_s = s.squaredNorm() / static_cast<double>(n);
  if (!(sigma_s > 1e-20))
    throw Error(ErrorCode::kInvalidArgument, "Umeyama alignment: all source points coincide");
  // 2. Cross-covariance, its SVD, and the reflection guard.
  const Eigen::Matrix3d cov = d * s.transpose() / static_cast<double>(n);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d sign = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) sign.z() = -1;
  Similarity out;
  out.R = svd.matrixU() * sign.asDiagonal() * svd.matrixV().transpose();
  // 3. Scale (trace(D S) / sigma) and translation.
  out.scale = with_scale ? svd.singularValues().dot(sign) / sigma_s : 1.0;
  out.t = mean_t - out.scale * out.R * mean_s;
  return out;
}

AteResult ComputeAte(const Trajectory& ref, const Trajectory& est, const AteParams& params) {
  if (!(params.max_dt_s >= 0) || !std::isfinite(params.max_dt_s)) {
    throw Error(ErrorCode::kInvalidArgument,
                "ATE: max_dt must be a non-negative number of seconds");
  }
  const Association pairs =
      AssociateByTime(ref, est, static_cast<int64_t>(std::llround(params.max_dt_s * 1e9)));
  const size_t n = pairs.ref_index.size();
  if (n == 0) {
    throw Error(ErrorCode::kInvalidArgument, "ATE: no poses of the two trajectories are within " +
                                                 std::to_string(params.max_dt_s) +
                                                 " s of each other");
  }
  Eigen::Matrix3Xd p_ref(3, n), p_est(3, n);
  for (size_t k = 0; k < n; ++k) {
    p_ref.col(k) = ref[pairs.ref_index[k]].T.translation();
    p_est.col(k) = est[pairs.est_index[k]].T.translation();
  }
  AteResult result;
  result.pairs = n;
  if (params.alignment != AteAlignment::kNone) {
    result.alignment = Umeyama(p_est, p_ref, params.alignment == AteAlignment::kSim3);
  }
  const Similarity& a = result.alignment;
  result.errors.resize(n);
  for (size_t k = 0; k < n; ++k) {
    result.errors[k] = (p_ref.col(k) - (a.scale * a.R * p_est.col(k) + a.t)).norm();
  }
  const auto& e = result.errors;
  result.sse =
      std::accumulate(e.begin(), e.end(), 0.0, [](double s, double v) { return s + v * v; });
  result.mean = std::accumulate(e.begin(), e.end(), 0.0) / n;
  result.rmse = std::sqrt(result.sse / n);
  double var = 0;
  for (double v : e) var += (v - result.mean) * (v - result.mean);
  result.std = std::sqrt(var / n);  // population std, as numpy's default
  std::vector<double> sorted = e;
  std::sort(sorted.begin(), sorted.end());
  result.min = sorted.front();
  result.max = sorted.back();
  result.median = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  return result;
}

}  // namespace mapdelta

// AlignGicp: Levenberg-Marquardt on SE(3) over GICP correspondences, then the covariance.
//
// Steps:
//  1. Linearize at T: for each source point find the nearest target point (k-d tree, through
//     CorrespondenceCache); keep it if closer than max_correspondence_m; accumulate
//     H = sum J^T W J, b = sum J^T W r, B = sum g g^T (g = J^T W r) and the error sum r^T W r,
//     in parallel ranges (linearization.hpp: the same sums, computed in the source frame).
//  2. Solve (H + lambda diag(H)) delta = -b. A step below the eps thresholds ends the loop.
//  3. Evaluate the error of the SAME correspondences at T (+) delta (a fair comparison: a
//     new search could change the set of terms); accept if it decreased
//     (lambda /= 10) else lambda *= 10 and retry.
//  4. Accepted: re-linearize at the new pose with fresh correspondences; repeat from 2.
//  5. Covariance from the last linearization (see RegistrationResult::covariance).
// Steps 3 and 4 are one pass over the source points (Pass): at the candidate pose each point
// gets the weight of its old correspondence (for the step test) and its new correspondence,
// which is usually the same one, so W is computed once for both. A rejected step throws the
// new linearization away, and the next candidates at that pose get a test-only pass (at the
// minimum several are rejected in a row). The weight is always computed at the candidate's
// rotation:
// reusing the last linearization's W in the step test (cheaper) let LM cycle without
// converging in 1 of 60 noisy trials.
// Convergence: a step below the eps thresholds, or a limit cycle. On noisy stereo clouds the
// nearest-neighbour assignment can alternate between a few sets, each step undoing the last
// (measured on the simulator's local clouds: a period-4 cycle of 0.6 mm steps that ran into the
// iteration cap and was rejected "not converged" in ~5% of registrations on sequences with
// little drift). A pose that returns within the eps thresholds to one of the last kCycleMemory
// accepted poses can only keep revisiting them: that is the minimum, reported as converged.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>

#include "correspondence_cache.hpp"
#include "gicp_cloud_access.hpp"
#include "linearization.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/parallel.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"

namespace mapdelta {
namespace {

using detail::Linearization;

constexpr double kInitialLambda = 1e-6;
constexpr double kMaxLambda = 1e6;
constexpr double kMinLambda = 1e-12;
// Variance given to directions the correspondences do not constrain at all (rad^2 or m^2).
constexpr double kUnobservedVariance = 1e6;
// After a rejected step, lambda is raised at least to this: below it the damped step differs
// from the rejected one by < 0.1% and would be rejected again. Measured on bench_registration:
// at the minimum a 0.6 mm step (eps 0.5 mm) was rejected 8 times from lambda 1e-9 to 1e-2.
constexpr double kRejectedLambdaFloor = 1e-3;
// Accepted poses remembered for the limit-cycle test.
constexpr size_t kCycleMemory = 8;
constexpr uint32_t kNone = detail::CorrespondenceCache::kNone;

// One pass at a pose: the linearization with fresh correspondences and, if there were
// earlier correspondences, their error at this pose (the step test).
struct PassResult {
  Linearization lin;
  double error_old = 0;
};

// The same, summing.
struct PassSums {
  detail::TermSums terms;
  double error_old = 0;
};

class Problem {
 public:
  Problem(const GicpCloud& target, const GicpCloud& source, const GicpParams& params)
      : target_(target),
        source_(source),
        params_(params),
        tree_(detail::GicpCloudAccess::Tree(target)),
        cache_(source.size(), static_cast<float>(params.max_correspondence_m)),
        accepted_(source.size(), kNone),
        candidate_(source.size(), kNone) {}

  // What a pass over the source points computes at a pose.
  enum class Work {
    kLinearize,  // fresh correspondences and the Gauss-Newton system
    kStepTest,   // only the error of the accepted correspondences
    kStepTestAndLinearize,
  };

  detail::Sym3 Weight(const Eigen::Matrix3d& Rt, const Eigen::Vector3f& target_normal,
                      const Eigen::Vector3f& source_normal) const {
    return params_.source_as_points ? detail::PointToPlaneWeight(Rt, target_normal)
                                    : detail::SourceFrameWeight(Rt, target_normal, source_normal);
  }

  PassResult Pass(const SE3& T, Work work) {
    const auto start = std::chrono::steady_clock::now();
    const bool test = work != Work::kLinearize, linearize = work != Work::kStepTest;
    const Eigen::Matrix3d Rt = T.linear().transpose();
    const auto& tp = target_.points();
    const auto& tn = detail::GicpCloudAccess::Normals(target_);
    const auto& sp = source_.points();
    const auto& sn = detail::GicpCloudAccess::Normals(source_);
    auto parts = ParallelRanges(
        source_.size(), params_.num_threads, PassSums{},
        [&](size_t begin, size_t end, PassSums& part) {
          for (size_t i = begin; i < end; ++i) {
            const Eigen::Vector3d s = sp[i].cast<double>();
            const Eigen::Vector3d Ts = T * s;
            const uint32_t old_j = test ? accepted_[i] : kNone;
            detail::Sym3 W_old{};
            Eigen::Vector3d u_old = Eigen::Vector3d::Zero();
            if (old_j != kNone) {
              W_old = Weight(Rt, tn[old_j], sn[i]);
              u_old = Rt * (tp[old_j].cast<double>() - Ts);
              part.error_old += detail::WeightedError(W_old, u_old);
            }
            if (!linearize) continue;
            float distance = 0;
            const uint32_t j =
                cache_.Find(i, Ts.cast<float>(), i > begin ? i - 1 : kNone, tp, tree_, &distance);
            candidate_[i] = j;
            if (j == kNone) continue;
            if (j == old_j) {
              detail::AddTerm(s, u_old, W_old, distance, &part.terms);
            } else {
              detail::AddTerm(s, Rt * (tp[j].cast<double>() - Ts), Weight(Rt, tn[j], sn[i]),
                              distance, &part.terms);
            }
          }
        });
    PassSums total;
    MD_LOG(
        kDebug,
        "AlignGicp: pass ("
            << (test ? "step test" : "") << (test && linearize ? ", " : "")
            << (linearize ? "linearize" : "") << ") "
            << 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
            << " ms, " << cache_.searches() << " searches so far");
    for (const auto& p : parts) {
      total.terms.Add(p.terms);
      total.error_old += p.error_old;
    }
    return {detail::Expand(total.terms), total.error_old};
  }

  // The last pass's correspondences become the accepted ones.
  void Accept() { accepted_.swap(candidate_); }

  size_t searches() const { return cache_.searches(); }

 private:
  const GicpCloud& target_;
  const GicpCloud& source_;
  const GicpParams& params_;
  const detail::KdTree& tree_;
  detail::CorrespondenceCache cache_;
  std::vector<uint32_t> accepted_;   // per source point: target index or kNone
  std::vector<uint32_t> candidate_;  // the same for the last pass
};

bool SmallStep(const Vector6d& delta, const GicpParams& params) {
  return delta.head<3>().norm() < params.rotation_eps_rad &&
         delta.tail<3>().norm() < params.translation_eps_m;
}

// True if T is within the eps thresholds of one of the earlier poses (a limit cycle).
bool RevisitsPose(const SE3& T, const std::vector<SE3>& earlier, const GicpParams& params) {
  for (const SE3& E : earlier) {
    if (SmallStep(LocalRight(E, T), params)) return true;
  }
  return false;
}

// Step 5: sandwich covariance H^-1 B H^-1 with a small-sample factor; directions with no
// information (eigenvalue of H ~ 0) get kUnobservedVariance instead of 0/0.
Matrix6d SandwichCovariance(const Linearization& lin, double scale) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(lin.H);
  const Vector6d values = eig.eigenvalues();
  const Matrix6d& V = eig.eigenvectors();
  const double floor = std::max(values.maxCoeff(), 0.0) * 1e-9;
  Vector6d inverse = Vector6d::Zero();
  Vector6d unobserved = Vector6d::Zero();
  for (int k = 0; k < 6; ++k) {
    if (values(k) > floor && values(k) > 0) {
      inverse(k) = 1.0 / values(k);
    } else {
      unobserved(k) = kUnobservedVariance;
    }
  }
  const Matrix6d Hinv = V * inverse.asDiagonal() * V.transpose();
  const double n = static_cast<double>(lin.inliers);
  const double small_sample = n > 7 ? n / (n - 6.0) : 1.0;
  Matrix6d cov = small_sample * (Hinv * lin.B * Hinv);
  cov += V * unobserved.asDiagonal() * V.transpose();
  cov = 0.5 * (cov + cov.transpose()).eval();
  return scale * cov;
}

Eigen::Vector3d Centroid(const PointCloud& cloud) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : cloud) sum += p.cast<double>();
  return cloud.empty() ? sum : Eigen::Vector3d(sum / static_cast<double>(cloud.size()));
}

}  // namespace

RegistrationResult AlignGicp(const GicpCloud& target, const GicpCloud& source,
                             const SE3& init_T_target_source, const GicpParams& params) {
  ValidateGicpParams(params);
  if (!init_T_target_source.matrix().allFinite()) {
    throw Error(ErrorCode::kInvalidArgument, "AlignGicp: init_T_target_source is not finite");
  }
  RegistrationResult result;
  result.T_target_source = init_T_target_source;
  result.num_source_points = source.size();
  result.source_centroid = Centroid(source.points());
  result.covariance = Matrix6d::Identity() * kUnobservedVariance;
  if (target.size() < 6 || source.size() < 6) {
    MD_LOG(kDebug, "AlignGicp: too few points (target " << target.size() << ", source "
                                                        << source.size() << ")");
    return result;
  }

  Problem problem(target, source, params);
  SE3 T = init_T_target_source;
  Linearization lin = problem.Pass(T, Problem::Work::kLinearize).lin;
  problem.Accept();
  double lambda = kInitialLambda;
  bool converged = false;
  int iteration = 0;
  std::vector<SE3> visited{T};  // the last kCycleMemory accepted poses
  for (; iteration < params.max_iterations && !converged; ++iteration) {
    if (lin.inliers < 6) break;
    bool accepted = false;
    // The first candidate at a pose is usually accepted: test it and linearize there in one
    // pass. After a rejection, further candidates get the cheaper test-only pass.
    bool rejected = false;
    while (!accepted && !converged) {
      Matrix6d A = lin.H;
      A.diagonal() += lambda * lin.H.diagonal().cwiseMax(1e-9);
      const Vector6d delta = A.ldlt().solve(-lin.b);
      if (!delta.allFinite()) break;
      if (SmallStep(delta, params)) {
        converged = true;  // the minimum for these correspondences: nothing left to take
        break;
      }
      MD_LOG(kDebug, "AlignGicp: iteration " << iteration << " lambda " << lambda << " step "
                                             << delta.head<3>().norm() << " rad "
                                             << delta.tail<3>().norm() << " m, error " << lin.error
                                             << ", inliers " << lin.inliers);
      const SE3 candidate = RetractRight(T, delta);
      PassResult pass = problem.Pass(
          candidate, rejected ? Problem::Work::kStepTest : Problem::Work::kStepTestAndLinearize);
      if (pass.error_old < lin.error) {
        T = candidate;
        lambda = std::max(lambda / 10.0, kMinLambda);
        accepted = true;
        lin = rejected ? problem.Pass(T, Problem::Work::kLinearize).lin : pass.lin;
        problem.Accept();
        // The previous pose is one small step away by construction; a revisit of an older one
        // is a cycle of correspondence sets.
        converged = SmallStep(delta, params) ||
                    RevisitsPose(T, std::vector<SE3>(visited.begin(), visited.end() - 1), params);
        if (converged && !SmallStep(delta, params)) {
          MD_LOG(kDebug,
                 "AlignGicp: correspondence cycle at iteration " << iteration << ": converged");
        }
        visited.push_back(T);
        if (visited.size() > kCycleMemory) visited.erase(visited.begin());
      } else {
        rejected = true;
        lambda = std::max(lambda * 10.0, kRejectedLambdaFloor);
        // Steps ~1e-6 of Gauss-Newton's that still do not descend: a numerical minimum.
        if (lambda > kMaxLambda) converged = true;
      }
    }
    if (!accepted && !converged) break;  // a non-finite step: give up, not converged
  }

  result.T_target_source = T;
  result.converged = converged && lin.inliers >= 6;
  result.iterations = iteration;
  result.num_inliers = lin.inliers;
  result.H = lin.H;
  result.b = lin.b;
  result.error = lin.error;
  result.fitness_m = lin.inliers > 0 ? lin.distance_sum / static_cast<double>(lin.inliers) : 0;
  if (lin.inliers >= 6) result.covariance = SandwichCovariance(lin, params.covariance_scale);
  MD_LOG(kDebug, "AlignGicp: converged=" << result.converged << " iterations=" << iteration
                                         << " inliers=" << lin.inliers << "/" << source.size()
                                         << " fitness=" << result.fitness_m << " m, "
                                         << problem.searches() << " searches");
  return result;
}

RegistrationResult AlignGicp(const GicpCloud& target, const PointCloud& source,
                             const SE3& init_T_target_source, const GicpParams& params) {
  return AlignGicp(target, GicpCloud(source, params), init_T_target_source, params);
}

RegistrationResult AlignGicp(const PointCloud& target, const PointCloud& source,
                             const SE3& init_T_target_source, const GicpParams& params) {
  if (params.num_threads < 2) {
    return AlignGicp(GicpCloud(target, params), GicpCloud(source, params), init_T_target_source,
                     params);
  }
  // Both clouds side by side, the target's k-d tree with it; each cloud's own loops then run
  // on its thread alone (nested loops are serial: parallel.hpp). Inside one cloud the
  // voxelization, cell sort and tree build are serial anyway.
  std::optional<GicpCloud> prepared_target, prepared_source;
  ParallelFor(2, 2, [&](size_t job) {
    if (job == 0) {
      prepared_source.emplace(source, params);
    } else {
      prepared_target.emplace(target, params);
      detail::GicpCloudAccess::Tree(*prepared_target);
    }
  });
  return AlignGicp(*prepared_target, *prepared_source, init_T_target_source, params);
}

}  // namespace mapdelta

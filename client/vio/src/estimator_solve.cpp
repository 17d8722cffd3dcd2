// Optimization, outlier removal, marginalization and covariance of the sliding window.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "mapdelta/common/lie.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/vio/estimator.hpp"
#include "mapdelta/vio/gauge.hpp"

namespace mapdelta::vio {

namespace {

// The window's Hessian reduced onto two poses still has its gauge (position and yaw): its
// directions, with eigenvalues at numerical-noise level relative to the largest, stay out of
// the covariance.
constexpr EigenvalueCutoff kWindowCovarianceCutoff{0, 1e-10};

PoseManifold& SharedPoseManifold() {
  static PoseManifold manifold;
  return manifold;
}

// Reprojection error of a factor functor (anchor pose, frame pose, inverse depth) in sigmas:
// the functors are scaled by weight_.
template <typename F>
double ErrorSigmas(const F& f, const double* anchor_pose, const double* pose,
                   const double* inv_depth) {
  double r[2];
  f(anchor_pose, pose, inv_depth, r);
  return std::hypot(r[0], r[1]);
}
}  // namespace

void SlidingWindowEstimator::LandmarkFactors(Landmark* lm, FactorList* out) const {
  if (!lm->has_depth || lm->obs.size() < 2) return;
  const auto& [t_anchor, a] = *lm->obs.begin();
  Frame* anchor = FindFrame(t_anchor);
  for (const auto& [t, obs] : lm->obs) {
    if (t == t_anchor) {
      if (obs.has_right) {
        out->push_back(
            {StereoFactor::Create(a.left, obs.right, cam0_, cam1_, weight_), {&lm->inv_depth}});
      }
      continue;
    }
    Frame* f = FindFrame(t);
    out->push_back({ReprojectionFactor::Create(a.left, obs.left, cam0_, cam0_, weight_,
                                               config_.analytic_reprojection),
                    {anchor->pose, f->pose, &lm->inv_depth}});
    if (obs.has_right && config_.right_in_other_frames) {
      out->push_back({ReprojectionFactor::Create(a.left, obs.right, cam0_, cam1_, weight_,
                                                 config_.analytic_reprojection),
                      {anchor->pose, f->pose, &lm->inv_depth}});
    }
  }
}

void SlidingWindowEstimator::AllFactors(FactorList* out) {
  for (size_t k = 1; k < window_.size(); ++k) {
    Frame& a = *window_[k - 1];
    Frame& b = *window_[k];
    if (b.pre.dt() <= 0) continue;
    out->push_back({ImuFactor::Create(b.pre, gravity_), {a.pose, a.sb, b.pose, b.sb}});
  }
  if (prior_) out->push_back({new MarginalizationFactor(prior_), prior_->kept_blocks()});
  for (auto& [id, lm] : landmarks_) LandmarkFactors(&lm, out);
}

void SlidingWindowEstimator::Optimize(int iterations, double max_time_s, bool motion_only) {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(options);
  for (auto& f : window_) {
    problem.AddParameterBlock(f->pose, 7, &SharedPoseManifold());
    problem.AddParameterBlock(f->sb, 9);
  }
  FactorList factors;
  AllFactors(&factors);
  const Frame& newest = *window_.back();
  for (auto& [cost, blocks] : factors) {
    // Motion-only: just the factors of the newest frame (its IMU factor and observations).
    if (motion_only && std::find(blocks.begin(), blocks.end(), newest.pose) == blocks.end() &&
        std::find(blocks.begin(), blocks.end(), newest.sb) == blocks.end()) {
      delete cost;
      continue;
    }
    // Visual factors (all but IMU and prior) get the robust loss.
    const bool visual = cost->num_residuals() == 2;
    problem.AddResidualBlock(cost, visual ? loss_.get() : nullptr, blocks);
  }
  // The prior holds no gauge (MarginalizeOldest): the oldest frame keeps its position and yaw.
  // Nothing else in the problem acts along the gauge, so the anchor's stiffness only sets the
  // conditioning (1e-3 and 1e-7 gave the same trajectory on paper S2_02).
  if (config_.gauge_free_prior && !motion_only) {
    constexpr double kAnchorSigma = 1e-3;  // m and rad
    problem.AddResidualBlock(CreateGaugeAnchor(window_.front()->pose, kAnchorSigma), nullptr,
                             window_.front()->pose);
  }
  if (motion_only) {
    std::vector<double*> blocks;
    problem.GetParameterBlocks(&blocks);
    for (double* b : blocks) {
      if (b != newest.pose && b != newest.sb) problem.SetParameterBlockConstant(b);
    }
  }
  for (auto& [id, lm] : landmarks_) {
    if (problem.HasParameterBlock(&lm.inv_depth)) {
      problem.SetParameterLowerBound(&lm.inv_depth, 0, 1e-4);
    }
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_SCHUR;
  solver.trust_region_strategy_type = ceres::DOGLEG;
  solver.max_num_iterations = iterations;
  solver.max_solver_time_in_seconds = max_time_s;
  solver.num_threads = config_.solver_threads;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  MD_LOG(kDebug,
         "vio solve: " << summary.BriefReport() << " " << summary.total_time_in_seconds << " s");
}

void SlidingWindowEstimator::GateByPrediction(const Frame& frame, const FrameFeatures& features) {
  int dropped = 0, forgotten = 0, checked = 0;
  for (const auto& observed : features.features) {
    Landmark& lm = landmarks_.at(observed.id);
    if (!lm.has_depth || lm.obs.size() < 2 || lm.obs.begin()->first == frame.t_ns) continue;
    const auto& [t_anchor, a] = *lm.obs.begin();
    const double error =
        ErrorSigmas(ReprojectionFactor(a.left, observed.left, cam0_, cam0_, weight_),
                    FindFrame(t_anchor)->pose, frame.pose, &lm.inv_depth);
    ++checked;
    if (error <= config_.prediction_gate_sigmas) continue;
    if (lm.obs.size() > 2) {
      lm.obs.erase(frame.t_ns);
      ++dropped;
    } else {
      lm.has_depth = false;
      lm.left_only = true;
      for (auto& [t, o] : lm.obs) o.has_right = false;
      ++forgotten;
    }
  }
  if (dropped + forgotten > 0) {
    MD_LOG(kDebug, "vio: of " << checked << " observations off the prediction: " << dropped
                              << " dropped, " << forgotten << " landmark depths forgotten");
  }
}

void SlidingWindowEstimator::RemoveOutliers() {
  int removed = 0;
  for (auto& [id, lm] : landmarks_) {
    if (!lm.has_depth) continue;
    const auto& [t_anchor, a] = *lm.obs.begin();
    const Frame* anchor = FindFrame(t_anchor);
    for (auto it = std::next(lm.obs.begin()); it != lm.obs.end();) {
      const Frame* f = FindFrame(it->first);
      if (ErrorSigmas(ReprojectionFactor(a.left, it->second.left, cam0_, cam0_, weight_),
                      anchor->pose, f->pose, &lm.inv_depth) > config_.outlier_sigmas) {
        it = lm.obs.erase(it);
        ++removed;
        continue;
      }
      if (it->second.has_right &&
          ErrorSigmas(ReprojectionFactor(a.left, it->second.right, cam0_, cam1_, weight_),
                      anchor->pose, f->pose, &lm.inv_depth) > config_.outlier_sigmas) {
        it->second.has_right = false;
      }
      ++it;
    }
    if (lm.obs.begin()->second.has_right) {
      double r[2];
      StereoFactor(a.left, lm.obs.begin()->second.right, cam0_, cam1_, weight_)(&lm.inv_depth, r);
      if (std::hypot(r[0], r[1]) > config_.outlier_sigmas) lm.obs.begin()->second.has_right = false;
    }
    if (!(lm.inv_depth > 1e-3 && lm.inv_depth < 10.0)) lm.has_depth = false;
  }
  if (removed > 0) MD_LOG(kDebug, "vio: removed " << removed << " outlier observations");
}

void SlidingWindowEstimator::MarginalizeOldest() {
  Frame& oldest = *window_.front();
  auto marg = std::make_shared<Marginalizer>();
  if (prior_) {
    marg->AddResidualBlock(new MarginalizationFactor(prior_), nullptr, prior_->kept_blocks());
  }
  if (window_.size() > 1 && window_[1]->pre.dt() > 0) {
    Frame& next = *window_[1];
    marg->AddResidualBlock(ImuFactor::Create(next.pre, gravity_), nullptr,
                           {oldest.pose, oldest.sb, next.pose, next.sb});
  }
  for (auto& [id, lm] : landmarks_) {
    if (lm.obs.empty() || lm.obs.begin()->first != oldest.t_ns) continue;
    FactorList factors;
    LandmarkFactors(&lm, &factors);
    for (auto& [cost, blocks] : factors) marg->AddResidualBlock(cost, loss_.get(), blocks);
    if (!factors.empty()) marg->Drop(&lm.inv_depth);
  }
  marg->Drop(oldest.pose);
  marg->Drop(oldest.sb);
  if (marg->Marginalize()) {
    if (config_.gauge_free_prior) {
      marg->RemoveDirections(GaugeDirections(marg->kept_sizes(), marg->linearization_points()));
    }
    prior_ = marg;
  }
  finalized_.push_back({oldest.t_ns, StateOf(oldest), oldest.relative_covariance});
  RemoveFrameObservations(oldest.t_ns);
  window_.pop_front();
}

std::optional<Matrix6d> SlidingWindowEstimator::RelativeCovariance(const Frame& a, const Frame& b) {
  // 1. Linearize the whole window and reduce it onto the two poses (Schur complement).
  Marginalizer m;
  FactorList factors;
  AllFactors(&factors);
  for (auto& [cost, blocks] : factors) {
    m.AddResidualBlock(cost, cost->num_residuals() == 2 ? loss_.get() : nullptr, blocks);
    for (double* block : blocks) {
      if (block != a.pose && block != b.pose) m.Drop(block);
    }
  }
  if (!m.Marginalize() || m.kept_blocks().size() != 2) return std::nullopt;
  // 2. Covariance of the two poses (pseudo-inverse: the window has gauge freedom left).
  const Eigen::MatrixXd cov = PseudoInverse(m.H(), kWindowCovarianceCutoff);
  // 3. Propagate through T_a_b = T_w_a^-1 T_w_b, in the documented convention
  //    (tangent [rotation, translation], right perturbation T_a_b * Exp(xi)), numerically.
  const bool a_first = m.kept_blocks()[0] == a.pose;
  double xa[7], xb[7];
  std::copy(a.pose, a.pose + 7, xa);
  std::copy(b.pose, b.pose + 7, xb);
  const SE3 T0 = ArrayToPose(xa).inverse() * ArrayToPose(xb);
  Eigen::Matrix<double, 6, 12> J;
  const double h = 1e-6;
  for (int k = 0; k < 12; ++k) {
    double delta[6] = {0, 0, 0, 0, 0, 0};
    delta[k % 6] = h;
    double pa[7], pb[7];
    std::copy(xa, xa + 7, pa);
    std::copy(xb, xb + 7, pb);
    const bool perturb_a = (k < 6) == a_first;
    if (perturb_a)
      SharedPoseManifold().Plus(xa, delta, pa);
    else
      SharedPoseManifold().Plus(xb, delta, pb);
    const SE3 dT = T0.inverse() * (ArrayToPose(pa).inverse() * ArrayToPose(pb));
    J.block<3, 1>(0, k) = LogQuaternion(Eigen::Quaterniond(dT.linear()).normalized()) / h;
    J.block<3, 1>(3, k) = dT.translation() / h;
  }
  const Matrix6d rel = J * cov * J.transpose();
  if (!rel.allFinite()) return std::nullopt;
  return 0.5 * (rel + rel.transpose());
}

}  // namespace mapdelta::vio

#include "mapdelta/client/pose_fusion.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <chrono>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/lie.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"

namespace mapdelta::client {
namespace {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

// Odometry between keyframes i and j: residual [Log(dR_meas^T R_i^T R_j), dR_meas^T (R_i^T
// (p_j - p_i) - dt_meas)], the right-perturbation tangent of the predicted relative motion
// around the measured one, whitened by U.
struct RelativePoseCost {
  Eigen::Quaterniond dq;
  Eigen::Vector3d dt;
  Matrix6 U;
  template <typename T>
  bool operator()(const T* qi, const T* pi, const T* qj, const T* pj, T* out) const {
    return Residual(qi, pi, qj, pj, T(1), out);
  }
  // With the measured translation scaled by `scale`.
  template <typename T>
  bool Residual(const T* qi_, const T* pi_, const T* qj_, const T* pj_, const T& scale,
                T* out) const {
    Eigen::Map<const Eigen::Quaternion<T>> qi(qi_), qj(qj_);
    Eigen::Map<const Vec3<T>> pi(pi_), pj(pj_);
    const Eigen::Quaternion<T> dq_inv = dq.conjugate().cast<T>();
    Eigen::Matrix<T, 6, 1> r;
    r.template head<3>() = LogQuaternion<T>(dq_inv * (qi.conjugate() * qj));
    r.template tail<3>() = dq_inv * (qi.conjugate() * (pj - pi) - scale * dt.cast<T>());
    Eigen::Map<Eigen::Matrix<T, 6, 1>> res(out);
    res = U.cast<T>() * r;
    return true;
  }
};

// The same with the odometry's scale state: the measured translation times exp(log_scale) of
// keyframe j.
struct ScaledRelativePoseCost {
  RelativePoseCost unscaled;
  template <typename T>
  bool operator()(const T* qi, const T* pi, const T* qj, const T* pj, const T* log_scale,
                  T* out) const {
    return unscaled.Residual(qi, pi, qj, pj, exp(log_scale[0]), out);
  }
};

// The log scale's random walk between consecutive keyframes, and its prior (0) at a
// segment's first keyframe, each whitened by 1 / sigma.
struct LogScaleStepCost {
  double inv_sigma;
  template <typename T>
  bool operator()(const T* a, const T* b, T* out) const {
    out[0] = inv_sigma * (b[0] - a[0]);
    return true;
  }
};
struct LogScalePriorCost {
  double inv_sigma;
  template <typename T>
  bool operator()(const T* a, T* out) const {
    out[0] = inv_sigma * a[0];
    return true;
  }
};

// A full-pose prior (the start-up pose), same tangent as above.
struct PosePriorCost {
  Eigen::Quaterniond q_meas;
  Eigen::Vector3d p_meas;
  Matrix6 U;
  template <typename T>
  bool operator()(const T* q_, const T* p_, T* out) const {
    Eigen::Map<const Eigen::Quaternion<T>> q(q_);
    Eigen::Map<const Vec3<T>> p(p_);
    const Eigen::Quaternion<T> q_inv = q_meas.conjugate().cast<T>();
    Eigen::Matrix<T, 6, 1> r;
    r.template head<3>() = LogQuaternion<T>(q_inv * q);
    r.template tail<3>() = q_inv * (p - p_meas.cast<T>());
    Eigen::Map<Eigen::Matrix<T, 6, 1>> res(out);
    res = U.cast<T>() * r;
    return true;
  }
};

// The paper's global position factor: p_k^p - p_k (whitened).
struct GlobalPositionCost {
  Eigen::Vector3d p_meas;
  Eigen::Matrix3d U;
  template <typename T>
  bool operator()(const T* p_, T* out) const {
    Eigen::Map<const Vec3<T>> p(p_);
    Eigen::Map<Vec3<T>> res(out);
    res = U.cast<T>() * (p - p_meas.cast<T>());
    return true;
  }
};

// The paper's relative rotation factor: (q_a^p)^-1 q_k^p (-) q_a^-1 q_k (whitened).
struct RelativeRotationCost {
  Eigen::Quaterniond z;  // (q_a^p)^-1 q_k^p
  Eigen::Matrix3d U;
  template <typename T>
  bool operator()(const T* qa_, const T* qk_, T* out) const {
    Eigen::Map<const Eigen::Quaternion<T>> qa(qa_), qk(qk_);
    Eigen::Map<Vec3<T>> res(out);
    res = U.cast<T>() * LogQuaternion<T>(z.conjugate().cast<T>() * (qa.conjugate() * qk));
    return true;
  }
};

Eigen::Matrix3d SqrtInformation3(const Eigen::Matrix3d& covariance) {
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance.inverse());
  if (llt.info() != Eigen::Success) {
    throw Error(ErrorCode::kInvalidArgument, "fusion: 3x3 covariance is not positive definite");
  }
  return llt.matrixU();
}

Matrix6 DiagonalCovariance(double sigma_rot, double sigma_trans) {
  Matrix6 c = Matrix6::Zero();
  c.diagonal() << Eigen::Vector3d::Constant(sigma_rot * sigma_rot),
      Eigen::Vector3d::Constant(sigma_trans * sigma_trans);
  return c;
}

void CheckCovariance(const Matrix6& c, const char* what) {
  if (!c.allFinite() || !c.isApprox(c.transpose(), 1e-6)) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string("fusion: ") + what + " covariance must be finite and symmetric");
  }
}

}  // namespace

Matrix6 SqrtInformation(const Matrix6& covariance) {
  CheckCovariance(covariance, "a");
  const Eigen::LLT<Matrix6> llt(covariance.inverse());
  if (llt.info() != Eigen::Success || !covariance.inverse().allFinite()) {
    throw Error(ErrorCode::kInvalidArgument, "fusion: covariance is not positive definite");
  }
  return llt.matrixU();
}

PoseFusion::PoseFusion(const FusionConfig& config) : config_(config) {}

void PoseFusion::SetState(KeyframeState* s, const SE3& T) const {
  const Eigen::Quaterniond q(T.linear());
  s->q[0] = q.x();
  s->q[1] = q.y();
  s->q[2] = q.z();
  s->q[3] = q.w();
  for (int i = 0; i < 3; ++i) s->p[i] = T.translation()[i];
}

void PoseFusion::SetInitialPose(const SE3& T_map_body, const Matrix6& covariance) {
  if (!keyframes_.empty())
    throw Error(ErrorCode::kConflict, "fusion: initial pose after keyframes");
  if (!IsValidPose(T_map_body, 1e-6))
    throw Error(ErrorCode::kInvalidArgument, "fusion: bad initial pose");
  SqrtInformation(covariance);  // validates
  T_map_body0_ = T_map_body;
  initial_covariance_ = covariance;
  has_initial_ = true;
}

size_t PoseFusion::AddKeyframe(int64_t t_ns, const SE3& T_odom_body,
                               const std::optional<Matrix6>& rel_covariance, int segment,
                               const std::optional<OdometryBridge>& bridge) {
  if (!IsValidPose(T_odom_body, 1e-6)) {
    throw Error(ErrorCode::kInvalidArgument,
                "fusion: odometry pose is not a valid rigid transform");
  }
  if (rel_covariance) SqrtInformation(*rel_covariance);
  if (!keyframes_.empty() && t_ns <= keyframes_.back().t_ns) {
    throw Error(ErrorCode::kInvalidArgument, "fusion: keyframe times must increase");
  }
  KeyframeState s;
  s.t_ns = t_ns;
  s.T_odom_body = T_odom_body;
  s.rel_covariance = rel_covariance;
  s.segment = segment;
  if (keyframes_.empty()) {
    if (!has_initial_) {
      throw Error(ErrorCode::kConflict,
                  "fusion: SetInitialPose must come before the first keyframe");
    }
    SetState(&s, T_map_body0_);
    segments_.push_back({segment, 0, T_map_body0_, initial_covariance_, false});
  } else if (segment != keyframes_.back().segment) {
    // Odometry reset: the new pose is unrelated to the previous segment's frame.
    s.rel_covariance.reset();
    Matrix6 covariance;
    SE3 predicted;
    if (bridge) {
      if (!IsValidPose(bridge->T_prev_odom_body, 1e-6))
        throw Error(ErrorCode::kInvalidArgument, "fusion: bridge pose is not a rigid transform");
      SqrtInformation(bridge->covariance);  // validates
      predicted = FusedPose(keyframes_.size() - 1) * keyframes_.back().T_odom_body.inverse() *
                  bridge->T_prev_odom_body;
      covariance = bridge->covariance;
    } else {
      predicted = PredictAcrossGap(t_ns, &covariance);
    }
    SetState(&s, predicted);
    segments_.push_back(
        {segment, keyframes_.size(), predicted, covariance, false, bridge.has_value()});
  } else {
    const auto& prev = keyframes_.back();
    // The step at the previous keyframe's scale (1 without the scale state).
    SE3 step = prev.T_odom_body.inverse() * T_odom_body;
    s.log_scale[0] = prev.log_scale[0];
    step.translation() *= std::exp(s.log_scale[0]);
    SetState(&s, FusedPose(keyframes_.size() - 1) * step);
  }
  keyframes_.push_back(s);
  return keyframes_.size() - 1;
}

// Constant velocity from the last two fused poses of the ending segment (body-frame twist,
// right perturbation), extrapolated over the gap; zero velocity if the segment had one pose.
SE3 PoseFusion::PredictAcrossGap(int64_t t_ns, Matrix6* covariance) const {
  const size_t n = keyframes_.size();
  const SE3 last = FusedPose(n - 1);
  const double gap_s = 1e-9 * static_cast<double>(t_ns - keyframes_[n - 1].t_ns);
  SE3 predicted = last;
  if (n >= 2 && keyframes_[n - 2].segment == keyframes_[n - 1].segment) {
    const double dt_s = 1e-9 * static_cast<double>(keyframes_[n - 1].t_ns - keyframes_[n - 2].t_ns);
    const Eigen::Matrix<double, 6, 1> twist = LocalRight(FusedPose(n - 2), last);
    predicted = RetractRight(last, twist * (gap_s / dt_s));
  }
  const double sr = config_.reset_sigma_rot_rad + config_.reset_sigma_rot_per_s * gap_s;
  const double st = config_.reset_sigma_trans_m + config_.reset_sigma_trans_per_s * gap_s;
  *covariance = DiagonalCovariance(sr, st);
  return predicted;
}

size_t PoseFusion::SegmentIndex(size_t k) const {
  if (k >= keyframes_.size()) throw Error(ErrorCode::kInvalidArgument, "fusion: unknown keyframe");
  // Segments are in keyframe order: the last one starting at or before k.
  size_t i = segments_.size() - 1;
  while (segments_[i].first_k > k) --i;
  return i;
}

bool PoseFusion::SegmentAnchored(size_t k) const { return segments_[SegmentIndex(k)].anchored; }

void PoseFusion::AddRegistration(size_t k, const SE3& T_map_body, const Matrix6& covariance) {
  if (k >= keyframes_.size())
    throw Error(ErrorCode::kInvalidArgument, "fusion: registration of unknown keyframe");
  if (!IsValidPose(T_map_body, 1e-6))
    throw Error(ErrorCode::kInvalidArgument, "fusion: bad registration pose");
  SqrtInformation(covariance);
  Segment& segment = segments_[SegmentIndex(k)];
  registrations_.push_back({k, T_map_body, covariance, !segment.anchored});
  if (!segment.anchored && &segment != &segments_.front()) {
    // Re-anchoring: the constant-velocity guess may be far off (even in heading); start the
    // solver from the registration carried along the segment's odometry.
    const SE3 T_map_odom = T_map_body * keyframes_[k].T_odom_body.inverse();
    for (size_t j = segment.first_k; j < keyframes_.size() && keyframes_[j].segment == segment.id;
         ++j) {
      SetState(&keyframes_[j], T_map_odom * keyframes_[j].T_odom_body);
    }
  }
  segment.anchored = true;
  last_registered_ = std::max(last_registered_, static_cast<long>(k));
}

SE3 PoseFusion::FusedPose(size_t k) const {
  const auto& s = keyframes_.at(k);
  return MakeSE3(Eigen::Quaterniond(s.q[3], s.q[0], s.q[1], s.q[2]).normalized(),
                 Eigen::Vector3d(s.p[0], s.p[1], s.p[2]));
}

SE3 PoseFusion::OdometryPose(size_t k) const { return keyframes_.at(k).T_odom_body; }

SE3 PoseFusion::OdometryInMap(size_t k) const {
  const Segment& segment = segments_[SegmentIndex(k)];
  return segment.T_map_body_start * keyframes_.at(segment.first_k).T_odom_body.inverse() *
         keyframes_.at(k).T_odom_body;
}

void PoseFusion::ComputeCovariances(ceres::Problem* problem, const std::vector<size_t>& which,
                                    std::vector<std::optional<Matrix6>>* out) {
  ceres::Covariance::Options options;
  options.algorithm_type = ceres::SPARSE_QR;
  options.num_threads = 1;
  ceres::Covariance covariance(options);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (size_t k : which) {
    if (k >= keyframes_.size()) continue;
    const auto& s = keyframes_[k];
    blocks.push_back({s.q, s.q});
    blocks.push_back({s.q, s.p});
    blocks.push_back({s.p, s.p});
  }
  if (blocks.empty() || !covariance.Compute(blocks, problem)) return;
  for (size_t i = 0; i < which.size(); ++i) {
    if (which[i] >= keyframes_.size()) continue;
    const auto& s = keyframes_[which[i]];
    double qq[9], qp[9], pp[9];
    if (!covariance.GetCovarianceBlockInTangentSpace(s.q, s.q, qq) ||
        !covariance.GetCovarianceBlockInTangentSpace(s.q, s.p, qp) ||
        !covariance.GetCovarianceBlockInTangentSpace(s.p, s.p, pp)) {
      continue;
    }
    // Ceres' tangent: q (+) d = [cos|d|, sin|d| d/|d|] q, i.e. a LEFT rotation by the
    // rotation vector 2d (map frame); p (+) d = p + d.
    Matrix6 left;
    left.topLeftCorner<3, 3>() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(qq);
    left.topRightCorner<3, 3>() =
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(qp);
    left.bottomLeftCorner<3, 3>() = left.topRightCorner<3, 3>().transpose();
    left.bottomRightCorner<3, 3>() =
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(pp);
    // To our right perturbation (R Exp(w), t + R v): w = R^T (2 d_rot), v = R^T d_pos.
    const Eigen::Matrix3d Rt = FusedPose(which[i]).linear().transpose();
    Matrix6 J = Matrix6::Zero();
    J.topLeftCorner<3, 3>() = 2.0 * Rt;
    J.bottomRightCorner<3, 3>() = Rt;
    (*out)[i] = J * left * J.transpose();
  }
}

FusionSummary PoseFusion::Optimize(int max_iterations, const std::vector<size_t>& covariance_of,
                                   std::vector<std::optional<Matrix6>>* covariances) {
  FusionSummary summary;
  if (keyframes_.empty()) return summary;
  const auto start = std::chrono::steady_clock::now();
  ceres::Problem problem;
  for (auto& s : keyframes_) {
    problem.AddParameterBlock(s.q, 4, new ceres::EigenQuaternionManifold);
    problem.AddParameterBlock(s.p, 3);
  }
  // 1. Start-up prior on keyframe 0; after each odometry reset, the constant-velocity
  //    prediction on the new segment's first keyframe.
  for (const Segment& segment : segments_) {
    // A re-anchored segment's prediction is superseded by its registration (the prediction
    // cannot know about a stop, reversal or heading change during the gap).
    if (segment.anchored && &segment != &segments_.front()) continue;
    auto* cost = new ceres::AutoDiffCostFunction<PosePriorCost, 6, 4, 3>(new PosePriorCost{
        Eigen::Quaterniond(segment.T_map_body_start.linear()),
        segment.T_map_body_start.translation(), SqrtInformation(segment.covariance)});
    auto& s = keyframes_[segment.first_k];
    problem.AddResidualBlock(cost, nullptr, s.q, s.p);
  }
  // 2. Odometry between consecutive keyframes of the same segment, with the scale state if
  //    configured (every keyframe then has a log scale block).
  const bool scale_state = config_.odom_scale_sigma_per_sqrt_s > 0;
  if (scale_state) {
    for (auto& s : keyframes_) problem.AddParameterBlock(s.log_scale, 1);
  }
  for (size_t k = 1; k < keyframes_.size(); ++k) {
    auto& a = keyframes_[k - 1];
    auto& b = keyframes_[k];
    if (a.segment != b.segment) continue;
    const SE3 dT = a.T_odom_body.inverse() * b.T_odom_body;
    const double step = dT.translation().norm();
    const Matrix6 cov = b.rel_covariance
                            ? *b.rel_covariance
                            : DiagonalCovariance(config_.odom_sigma_rot_rad,
                                                 config_.odom_sigma_trans_m +
                                                     config_.odom_sigma_trans_per_m * step);
    const RelativePoseCost relative{Eigen::Quaterniond(dT.linear()), dT.translation(),
                                    SqrtInformation(cov)};
    if (!scale_state) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 4, 3, 4, 3>(
                                   new RelativePoseCost(relative)),
                               nullptr, a.q, a.p, b.q, b.p);
      continue;
    }
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<ScaledRelativePoseCost, 6, 4, 3, 4, 3, 1>(
            new ScaledRelativePoseCost{relative}),
        nullptr, a.q, a.p, b.q, b.p, b.log_scale);
    const double dt_s = std::max(1e-3, 1e-9 * static_cast<double>(b.t_ns - a.t_ns));
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<LogScaleStepCost, 1, 1, 1>(
            new LogScaleStepCost{1.0 / (config_.odom_scale_sigma_per_sqrt_s * std::sqrt(dt_s))}),
        nullptr, a.log_scale, b.log_scale);
  }
  if (scale_state) {
    for (const Segment& segment : segments_) {
      auto& s = keyframes_[segment.first_k];
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LogScalePriorCost, 1, 1>(
                                   new LogScalePriorCost{1.0 / config_.odom_scale_sigma}),
                               nullptr, s.log_scale);
    }
  }
  // 3. Registration factors (robust): global position, and rotation relative to the first
  //    registered keyframe.
  //    The first registration (the start-up fix, which sets the absolute heading the paper
  //    assumes known) enters as a full 6-DoF pose factor with its full covariance, and so
  //    does the first registration of every later odometry segment (its re-anchoring).
  const Registration* anchor = registrations_.empty() ? nullptr : &registrations_.front();
  for (const auto& reg : registrations_) {
    auto& s = keyframes_[reg.k];
    const Eigen::Matrix3d R = reg.T_map_body.linear();
    if (reg.segment_first) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<PosePriorCost, 6, 4, 3>(
              new PosePriorCost{Eigen::Quaterniond(R), reg.T_map_body.translation(),
                                SqrtInformation(reg.covariance)}),
          new ceres::HuberLoss(config_.huber_delta), s.q, s.p);
      continue;
    }
    // Right-perturbed translation v maps to the map frame as R v.
    const Eigen::Matrix3d cov_p = R * reg.covariance.bottomRightCorner<3, 3>() * R.transpose();
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<GlobalPositionCost, 3, 3>(
            new GlobalPositionCost{reg.T_map_body.translation(), SqrtInformation3(cov_p)}),
        new ceres::HuberLoss(config_.huber_delta), s.p);
    if (reg.k == anchor->k) continue;
    const Eigen::Matrix3d R_rel = anchor->T_map_body.linear().transpose() * R;
    // z = R_a^T R_k: a right perturbation w_a of R_a moves z by -R_rel^T w_a.
    const Eigen::Matrix3d cov_r =
        R_rel.transpose() * anchor->covariance.topLeftCorner<3, 3>() * R_rel +
        reg.covariance.topLeftCorner<3, 3>();
    auto& a = keyframes_[anchor->k];
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<RelativeRotationCost, 3, 4, 4>(
            new RelativeRotationCost{Eigen::Quaterniond(R_rel), SqrtInformation3(cov_r)}),
        new ceres::HuberLoss(config_.huber_delta), a.q, s.q);
  }

  ceres::Solver::Options options;
  options.max_num_iterations = std::max(1, max_iterations);
  options.linear_solver_type =
      ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ||
              ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)
          ? ceres::SPARSE_NORMAL_CHOLESKY
          : ceres::DENSE_QR;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary result;
  ceres::Solve(options, &problem, &result);
  summary.iterations = static_cast<int>(result.iterations.size());
  summary.initial_cost = result.initial_cost;
  summary.final_cost = result.final_cost;
  summary.usable = result.IsSolutionUsable();
  if (covariances != nullptr) {
    covariances->assign(covariance_of.size(), std::nullopt);
    ComputeCovariances(&problem, covariance_of, covariances);
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace mapdelta::client

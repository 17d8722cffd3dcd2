#include "mapdelta/vio/estimator.hpp"

#include <chrono>
#include <cmath>

#include "mapdelta/common/log.hpp"
#include "mapdelta/vio/gauge.hpp"

namespace mapdelta::vio {
namespace {

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

CameraExtrinsics ToCamera(const SE3& T_body_cam) {
  CameraExtrinsics c;
  c.q_body_cam = Eigen::Quaterniond(T_body_cam.linear()).normalized();
  c.t_body_cam = T_body_cam.translation();
  return c;
}

// Prior on the first frame: position and yaw (the gauge VIO cannot observe) and the biases.
struct StatePrior {
  Eigen::Vector3d p0;
  Eigen::Quaterniond q0;
  Eigen::Vector3d bg0, ba0;
  double sigma_p = 0.01, sigma_yaw = 0.01, sigma_bg = 0.02, sigma_ba = 0.05;
  // Root of the biases' squared normalized shifts from bg0, ba0 (the prior's bias part).
  double BiasShiftSigmas(const NavState& s) const {
    return std::sqrt(((s.bg - bg0) / sigma_bg).squaredNorm() +
                     ((s.ba - ba0) / sigma_ba).squaredNorm());
  }
  template <typename T>
  bool operator()(const T* pose, const T* sb, T* r) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const V3> p(pose);
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose + 3);
    for (int k = 0; k < 3; ++k) {
      r[k] = (p[k] - T(p0[k])) / T(sigma_p);
      r[4 + k] = (sb[3 + k] - T(bg0[k])) / T(sigma_bg);
      r[7 + k] = (sb[6 + k] - T(ba0[k])) / T(sigma_ba);
    }
    r[3] = WorldYawError(q0, Eigen::Quaternion<T>(q)) / T(sigma_yaw);
    return true;
  }
};

}  // namespace

SlidingWindowEstimator::SlidingWindowEstimator(const VioConfig& config,
                                               const StereoExtrinsics& extrinsics)
    : config_(config),
      ext_(extrinsics),
      cam0_(ToCamera(extrinsics.T_body_cam0)),
      cam1_(ToCamera(extrinsics.T_body_cam1)),
      weight_(extrinsics.focal_px / config.pixel_sigma),
      gravity_(0, 0, -config.gravity),
      loss_(std::make_unique<ceres::HuberLoss>(config.huber_sigmas)) {}

SlidingWindowEstimator::~SlidingWindowEstimator() = default;

SlidingWindowEstimator::Frame* SlidingWindowEstimator::FindFrame(int64_t t_ns) const {
  for (const auto& f : window_) {
    if (f->t_ns == t_ns) return f.get();
  }
  return nullptr;
}

NavState SlidingWindowEstimator::StateOf(const Frame& f) const {
  NavState s;
  s.T_world_body = ArrayToPose(f.pose);
  s.v_world = Eigen::Map<const Eigen::Vector3d>(f.sb);
  s.bg = Eigen::Map<const Eigen::Vector3d>(f.sb + 3);
  s.ba = Eigen::Map<const Eigen::Vector3d>(f.sb + 6);
  return s;
}

std::optional<NavState> SlidingWindowEstimator::Start(std::vector<InitFrame> frames) {
  window_.clear();
  landmarks_.clear();
  prior_.reset();
  for (auto& init : frames) {
    auto f = std::make_unique<Frame>();
    f->t_ns = init.features.t_ns;
    PoseToArray(init.state.T_world_body, f->pose);
    Eigen::Map<Eigen::Vector3d>{f->sb} = init.state.v_world;
    Eigen::Map<Eigen::Vector3d>{f->sb + 3} = init.state.bg;
    Eigen::Map<Eigen::Vector3d>{f->sb + 6} = init.state.ba;
    f->pre = std::move(init.pre);
    window_.push_back(std::move(f));
    AddObservations(init.features);
  }
  for (auto& [id, lm] : landmarks_) Triangulate(&lm);
  // The gauge prior on the first frame starts the marginalization chain.
  Frame& first = *window_.front();
  StatePrior prior;
  prior.sigma_bg = config_.init_gyro_bias_sigma;
  prior.sigma_ba = config_.init_accel_bias_sigma;
  prior.p0 = Eigen::Map<const Eigen::Vector3d>(first.pose);
  prior.q0 = Eigen::Map<const Eigen::Quaterniond>(first.pose + 3);
  prior.bg0 = Eigen::Map<const Eigen::Vector3d>(first.sb + 3);
  prior.ba0 = Eigen::Map<const Eigen::Vector3d>(first.sb + 6);
  prior_ = std::make_shared<Marginalizer>();
  prior_->AddResidualBlock(
      new ceres::AutoDiffCostFunction<StatePrior, 10, 7, 9>(new StatePrior(prior)), nullptr,
      {first.pose, first.sb});
  prior_->Marginalize();
  // The linear alignment's gravity is a few degrees off (frame-to-frame PnP positions are
  // noisy over a short chain); a converged joint solve fixes the tilt before the first
  // output instead of letting it leak out over the next seconds.
  Optimize(config_.init_solver_iterations, config_.init_solver_max_time_s);
  RemoveOutliers();
  Optimize(config_.init_solver_iterations, config_.init_solver_max_time_s);
  const NavState newest = StateOf(*window_.back());
  const double shift = prior.BiasShiftSigmas(newest);
  const bool accepted = shift <= config_.init_max_bias_shift_sigmas;
  MD_LOG(kInfo, "vio init " << (accepted ? "accepted" : "rejected")
                            << ": the first solve moved the biases by " << shift << " sigmas (bg "
                            << newest.bg.transpose() << " rad/s, ba " << newest.ba.transpose()
                            << " m/s^2)" << (accepted ? "" : "; initializing again"));
  if (!accepted) return std::nullopt;
  while (static_cast<int>(window_.size()) > config_.window_keyframes) MarginalizeOldest();
  return newest;
}

void SlidingWindowEstimator::AddObservations(const FrameFeatures& features) {
  for (const auto& obs : features.features) {
    Landmark& lm = landmarks_[obs.id];
    FeatureObservation& added = lm.obs[features.t_ns] = obs;
    if (lm.left_only) added.has_right = false;
  }
}

Eigen::Vector3d SlidingWindowEstimator::LandmarkWorld(const Landmark& lm) const {
  const auto& [t_anchor, obs] = *lm.obs.begin();
  const Frame* anchor = FindFrame(t_anchor);
  const Eigen::Vector3d p_cam = Eigen::Vector3d(obs.left.x(), obs.left.y(), 1.0) / lm.inv_depth;
  return ArrayToPose(anchor->pose) * ext_.T_body_cam0 * p_cam;
}

void SlidingWindowEstimator::RemoveFrameObservations(int64_t t_ns) {
  for (auto it = landmarks_.begin(); it != landmarks_.end();) {
    Landmark& lm = it->second;
    const bool was_anchor = !lm.obs.empty() && lm.obs.begin()->first == t_ns;
    std::optional<Eigen::Vector3d> world;
    if (was_anchor && lm.has_depth && lm.obs.size() > 1) world = LandmarkWorld(lm);
    lm.obs.erase(t_ns);
    if (lm.obs.empty()) {
      it = landmarks_.erase(it);
      continue;
    }
    if (was_anchor) {
      // Move the depth to the new anchor so the estimate survives the anchor's removal.
      lm.has_depth = false;
      if (world) {
        const Frame* anchor = FindFrame(lm.obs.begin()->first);
        const Eigen::Vector3d p_cam =
            (ArrayToPose(anchor->pose) * ext_.T_body_cam0).inverse() * *world;
        if (p_cam.z() > 0.1) {
          lm.inv_depth = 1.0 / p_cam.z();
          lm.has_depth = true;
        }
      }
    }
    ++it;
  }
}

void SlidingWindowEstimator::Triangulate(Landmark* lm) const {
  // Rays of every observation (left and right) in the anchor's cam0 frame.
  const Frame* anchor = FindFrame(lm->obs.begin()->first);
  const SE3 T_w_c0a = ArrayToPose(anchor->pose) * ext_.T_body_cam0;
  const SE3 T_c0a_w = T_w_c0a.inverse();
  std::vector<Ray> rays;
  for (const auto& [t, obs] : lm->obs) {
    const Frame* f = FindFrame(t);
    const SE3 T_w_b = ArrayToPose(f->pose);
    const SE3 T_a_c0 = T_c0a_w * T_w_b * ext_.T_body_cam0;
    rays.push_back(
        {T_a_c0.translation(), T_a_c0.linear() * Eigen::Vector3d(obs.left.x(), obs.left.y(), 1)});
    if (obs.has_right) {
      const SE3 T_a_c1 = T_c0a_w * T_w_b * ext_.T_body_cam1;
      rays.push_back({T_a_c1.translation(),
                      T_a_c1.linear() * Eigen::Vector3d(obs.right.x(), obs.right.y(), 1)});
    }
  }
  const auto P = TriangulateRays(rays, 2e-3);
  if (!P || P->z() < 0.2 || P->z() > 500.0) return;
  // Depth along the anchor's left ray (its own pixel defines the landmark direction).
  lm->inv_depth = 1.0 / P->z();
  lm->has_depth = true;
}

bool SlidingWindowEstimator::IsKeyframe(const FrameFeatures& features) const {
  const Frame* last_kf = nullptr;
  for (auto it = window_.rbegin(); it != window_.rend(); ++it) {
    if ((*it)->keyframe) {
      last_kf = it->get();
      break;
    }
  }
  if (!last_kf) return true;
  if (1e-9 * static_cast<double>(features.t_ns - last_kf->t_ns) > config_.keyframe_max_gap_s)
    return true;
  int shared = 0;
  double parallax = 0;
  for (const auto& f : features.features) {
    const auto it = landmarks_.find(f.id);
    if (it == landmarks_.end()) continue;
    const auto o = it->second.obs.find(last_kf->t_ns);
    if (o == it->second.obs.end()) continue;
    ++shared;
    parallax += (f.left - o->second.left).norm();
  }
  if (shared < config_.keyframe_min_tracked) return true;
  return parallax / shared > config_.keyframe_parallax;
}

EstimatorOutput SlidingWindowEstimator::AddFrame(const FrameFeatures& features,
                                                 const ImuPreintegration& pre_in) {
  EstimatorOutput out;
  // 1-2. Drop a trailing non-keyframe, predict from the newest state.
  Frame& last = *window_.back();
  const NavState s_last = StateOf(last);
  ImuPreintegration pre = pre_in;
  pre.Reintegrate(s_last.bg, s_last.ba);
  Eigen::Quaterniond q_pred;
  Eigen::Vector3d p_pred, v_pred;
  pre.Predict(gravity_, Eigen::Quaterniond(s_last.T_world_body.linear()),
              s_last.T_world_body.translation(), s_last.v_world, &q_pred, &p_pred, &v_pred);
  if (!last.keyframe) {
    ImuPreintegration merged = last.pre;
    merged.Append(pre);
    pre = std::move(merged);
    RemoveFrameObservations(last.t_ns);
    window_.pop_back();
  }
  auto frame = std::make_unique<Frame>();
  frame->t_ns = features.t_ns;
  frame->keyframe = IsKeyframe(features);
  Eigen::Map<Eigen::Vector3d>{frame->pose} = p_pred;
  Eigen::Map<Eigen::Quaterniond>{frame->pose + 3} = q_pred.normalized();
  Eigen::Map<Eigen::Vector3d>{frame->sb} = v_pred;
  Eigen::Map<Eigen::Vector3d>{frame->sb + 3} = s_last.bg;
  Eigen::Map<Eigen::Vector3d>{frame->sb + 6} = s_last.ba;
  frame->pre = std::move(pre);
  Frame* added = frame.get();
  window_.push_back(std::move(frame));
  AddObservations(features);
  GateByPrediction(*added, features);
  // A non-keyframe leaves the window at the next frame: only its own state needs solving.
  const bool motion_only = !added->keyframe && config_.motion_only_non_keyframes;
  // A motion-only solve holds depths fixed: a depth triangulated from this frame's predicted
  // pose would be held at a value the prediction error shaped. Such landmarks wait for the
  // next keyframe, whose joint solve refines them.
  if (!motion_only) {
    for (auto& [id, lm] : landmarks_) {
      if (!lm.has_depth) Triangulate(&lm);
    }
  }

  // 3. Optimize and clean up.
  const auto t_opt = std::chrono::steady_clock::now();
  Optimize(config_.solver_iterations, config_.solver_max_time_s, motion_only);
  RemoveOutliers();
  out.optimize_ms = MsSince(t_opt);

  // 4. Re-linearize preintegrations whose start bias moved far; detect failure.
  for (size_t k = 1; k < window_.size(); ++k) {
    const NavState s = StateOf(*window_[k - 1]);
    if (window_[k]->pre.BiasMovedFar(s.bg, s.ba)) window_[k]->pre.Reintegrate(s.bg, s.ba);
  }
  out.state = StateOf(*added);
  out.keyframe = added->keyframe;
  out.landmarks = LandmarksSeenIn(added->t_ns);
  if (out.state.ba.norm() > config_.max_accel_bias || out.state.bg.norm() > config_.max_gyro_bias ||
      out.state.v_world.norm() > config_.max_speed || out.landmarks < config_.min_landmarks ||
      !out.state.T_world_body.matrix().allFinite()) {
    MD_LOG(kWarn, "vio failure at t_ns=" << features.t_ns << ": |ba|=" << out.state.ba.norm()
                                         << " |bg|=" << out.state.bg.norm()
                                         << " speed=" << out.state.v_world.norm()
                                         << " landmarks=" << out.landmarks);
    out.failed = true;
    return out;
  }

  // 5. Keyframe bookkeeping: covariance of the relative motion, then marginalization.
  if (added->keyframe) {
    if (config_.compute_keyframe_covariance) {
      const auto t_cov = std::chrono::steady_clock::now();
      for (int k = static_cast<int>(window_.size()) - 2; k >= 0; --k) {
        if (window_[k]->keyframe) {
          added->relative_covariance = RelativeCovariance(*window_[k], *added);
          break;
        }
      }
      out.relative_covariance = added->relative_covariance;
      out.covariance_ms = MsSince(t_cov);
    }
    const auto t_marg = std::chrono::steady_clock::now();
    while (static_cast<int>(window_.size()) > config_.window_keyframes) MarginalizeOldest();
    out.marginalize_ms = MsSince(t_marg);
  }
  return out;
}

int SlidingWindowEstimator::LandmarksSeenIn(int64_t t_ns) const {
  int n = 0;
  for (const auto& [id, lm] : landmarks_) {
    if (lm.has_depth && lm.obs.size() >= 2 && lm.obs.count(t_ns)) ++n;
  }
  return n;
}

std::vector<FinalizedKeyframe> SlidingWindowEstimator::TakeFinalized() {
  std::vector<FinalizedKeyframe> out;
  out.swap(finalized_);
  return out;
}

void SlidingWindowEstimator::Flush() {
  for (const auto& f : window_) {
    if (f->keyframe) finalized_.push_back({f->t_ns, StateOf(*f), f->relative_covariance});
  }
  window_.clear();
  landmarks_.clear();
  prior_.reset();
}

}  // namespace mapdelta::vio

#include "mapdelta/vio/initializer.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include <Eigen/Dense>
#include <unordered_map>

#include "mapdelta/common/log.hpp"
#include "mapdelta/vio/rest_detector.hpp"

namespace mapdelta::vio {

Initializer::Initializer(const VioConfig& config, const StereoExtrinsics& extrinsics)
    : config_(config), ext_(extrinsics) {}

std::optional<std::vector<InitFrame>> Initializer::AddFrame(const FrameFeatures& features,
                                                            const ImuPreintegration& pre) {
  InitFrame frame{features, pre, {}};
  if (!frames_.empty()) {
    // Against the anchor while it shares kAnchorMinInliers with this frame; then the previous
    // frame becomes the anchor.
    constexpr size_t kAnchorMinInliers = 40;
    SE3 T_anchor_cur;
    bool ok = RelativeMotion(frames_[anchor_].features, features, &T_anchor_cur,
                             anchor_ + 1 < frames_.size() ? kAnchorMinInliers : 10);
    if (!ok && anchor_ + 1 < frames_.size()) {
      anchor_ = frames_.size() - 1;
      ok = RelativeMotion(frames_[anchor_].features, features, &T_anchor_cur);
    }
    if (!ok) {
      MD_LOG(kDebug, "vio init: stereo PnP failed at t_ns=" << features.t_ns << ", restarting");
      frames_.clear();
      anchor_ = 0;
      frame.pre = ImuPreintegration(pre.noise(), pre.bg0(), pre.ba0());
    } else {
      const SE3& T_w_anchor = frames_[anchor_].state.T_world_body;
      frame.state.T_world_body =
          T_w_anchor * ext_.T_body_cam0 * T_anchor_cur * ext_.T_body_cam0.inverse();
    }
  }
  frames_.push_back(std::move(frame));
  if (config_.static_init.enabled) {
    if (auto at_rest = StartAtRest()) {
      frames_.clear();
      anchor_ = 0;
      return at_rest;
    }
  }
  const double span_s = 1e-9 * static_cast<double>(features.t_ns - frames_.front().features.t_ns);
  if (static_cast<int>(frames_.size()) < config_.init_frames || span_s < config_.init_min_span_s) {
    return std::nullopt;
  }
  std::vector<InitFrame> out(frames_.begin(), frames_.end());
  if (!Align(&out)) {
    frames_.pop_front();         // slide: try again with the next frame
    if (anchor_ > 0) --anchor_;  // a dropped anchor hands over to the new oldest frame
    return std::nullopt;
  }
  frames_.clear();
  anchor_ = 0;
  return out;
}

bool Initializer::RelativeMotion(const FrameFeatures& prev, const FrameFeatures& cur,
                                 SE3* T_prev_cur, size_t min_inliers) const {
  std::unordered_map<uint64_t, const FeatureObservation*> by_id;
  for (const auto& f : cur.features) by_id[f.id] = &f;
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  const SE3 T_c0_c1 = ext_.T_cam0_cam1();
  // Far points carry noisy depth (a few px of disparity); as regressors of the translation
  // they attenuate it: with every point up to 200 m the chain under-measured the motion by
  // 8-10% (tiny and paper S*_01), which biased the initial velocity and gravity (|g| 9.58).
  // Use points with disparity >= init_min_disparity_px; fall back to all if too few.
  const double z_near =
      ext_.focal_px * T_c0_c1.translation().norm() / config_.init_min_disparity_px;
  std::vector<cv::Point3f> far_object;
  std::vector<cv::Point2f> far_image;
  // The strongest, longest-tracked corners first (ids grow with detection order, and each
  // detection round takes the best corners first); see init_max_pnp_points. Stereo matches the
  // tracker found ambiguous (a repeated pattern: maybe a wrong period) only when fewer than 30
  // unambiguous ones are left (a short baseline makes many matches ambiguous).
  std::vector<const FeatureObservation*> candidates, ambiguous;
  for (const auto& f : prev.features) {
    if (f.has_right) (f.stereo_ambiguous ? ambiguous : candidates).push_back(&f);
  }
  const auto older_first = [](const FeatureObservation* a, const FeatureObservation* b) {
    return a->id < b->id;
  };
  std::sort(candidates.begin(), candidates.end(), older_first);
  if (candidates.size() < 30) {
    std::sort(ambiguous.begin(), ambiguous.end(), older_first);
    candidates.insert(candidates.end(), ambiguous.begin(), ambiguous.end());
  }
  if (static_cast<int>(candidates.size()) > config_.init_max_pnp_points) {
    candidates.resize(static_cast<size_t>(config_.init_max_pnp_points));
  }
  for (const FeatureObservation* fp : candidates) {
    const FeatureObservation& f = *fp;
    const auto it = by_id.find(f.id);
    if (it == by_id.end()) continue;
    const auto P = TriangulateStereo(f.left, f.right, T_c0_c1);
    if (!P || P->z() > 200.0) continue;
    const bool near = P->z() <= z_near;
    (near ? object : far_object).emplace_back(P->x(), P->y(), P->z());
    (near ? image : far_image).emplace_back(it->second->left.x(), it->second->left.y());
  }
  if (object.size() < 30) {
    object.insert(object.end(), far_object.begin(), far_object.end());
    image.insert(image.end(), far_image.begin(), far_image.end());
  }
  if (object.size() < 12) return false;
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const double threshold = 2.0 / ext_.focal_px;  // 2 px in normalized coordinates
  const bool ok =
      cv::solvePnPRansac(object, image, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false,
                         100, static_cast<float>(threshold), 0.99, inliers, cv::SOLVEPNP_ITERATIVE);
  if (!ok || inliers.size() < min_inliers) return false;
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  cv::cv2eigen(R_cv, R);
  cv::cv2eigen(tvec, t);
  SE3 T_cur_prev = SE3::Identity();
  T_cur_prev.linear() = R;
  T_cur_prev.translation() = t;
  *T_prev_cur = T_cur_prev.inverse();
  MD_LOG(kDebug, "vio init: PnP " << inliers.size() << "/" << object.size()
                                  << " inliers, |t|=" << t.norm());
  return true;
}

bool Initializer::Align(std::vector<InitFrame>* frames_ptr) const {
  auto& frames = *frames_ptr;
  const int n = static_cast<int>(frames.size());
  // 1. Gyro bias: visual rotation vs. preintegrated rotation, one Gauss-Newton step.
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int k = 1; k < n; ++k) {
    const auto& pre = frames[k].pre;
    const Eigen::Quaterniond R_ij(frames[k - 1].state.T_world_body.linear().transpose() *
                                  frames[k].state.T_world_body.linear());
    const Eigen::Matrix3d J = pre.J_R_bg();
    A += J.transpose() * J;
    b += J.transpose() * LogQuaternion((pre.dR().conjugate() * R_ij).normalized());
  }
  const Eigen::Vector3d bg = frames[1].pre.bg0() + A.ldlt().solve(b);
  if (!bg.allFinite() || bg.norm() > config_.max_gyro_bias) return false;
  for (int k = 1; k < n; ++k) frames[k].pre.Reintegrate(bg, frames[k].pre.ba0());

  // 2. Velocities v_0..v_{n-1} and gravity g in the first body frame (world of the chain):
  //    p_j - p_i - R_i dp = v_i dt + g dt^2 / 2 and R_i dv = v_j - v_i - g dt.
  const int unknowns = 3 * n + 3;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(6 * (n - 1), unknowns);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(6 * (n - 1));
  for (int k = 1; k < n; ++k) {
    const auto& pre = frames[k].pre;
    const double dt = pre.dt();
    const Eigen::Matrix3d R_i = frames[k - 1].state.T_world_body.linear();
    const Eigen::Vector3d p_i = frames[k - 1].state.T_world_body.translation();
    const Eigen::Vector3d p_j = frames[k].state.T_world_body.translation();
    const int row = 6 * (k - 1);
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    // Position rows divided by dt so both row kinds are in m/s.
    M.block<3, 3>(row, 3 * (k - 1)) = I;
    M.block<3, 3>(row, 3 * n) = 0.5 * dt * I;
    y.segment<3>(row) = (p_j - p_i - R_i * pre.dp()) / dt;
    M.block<3, 3>(row + 3, 3 * (k - 1)) = -I;
    M.block<3, 3>(row + 3, 3 * k) = I;
    M.block<3, 3>(row + 3, 3 * n) = -dt * I;
    y.segment<3>(row + 3) = R_i * pre.dv();
  }
  Eigen::VectorXd x = M.colPivHouseholderQr().solve(y);
  const Eigen::Vector3d g = x.tail<3>();
  if (!x.allFinite() ||
      std::abs(g.norm() - config_.gravity) > config_.init_max_gravity_error * config_.gravity) {
    MD_LOG(kDebug, "vio init: implausible gravity |g|=" << g.norm() << ", waiting");
    return false;
  }
  // 3. Fix |g| and re-solve the velocities with gravity known.
  const Eigen::Vector3d g_fixed = g.normalized() * config_.gravity;
  const Eigen::VectorXd y_fixed = y - M.rightCols<3>() * g_fixed;
  const Eigen::VectorXd v = M.leftCols(3 * n).colPivHouseholderQr().solve(y_fixed);
  const double rms = std::sqrt((M.leftCols(3 * n) * v - y_fixed).squaredNorm() / y.size());
  if (rms > config_.init_max_velocity_rms_mps) {
    MD_LOG(kDebug, "vio init: velocity fit residual " << rms << " m/s too large, waiting");
    return false;
  }
  // 4. Rotate the chain so gravity points along -z.
  const Eigen::Matrix3d R_align =
      Eigen::Quaterniond::FromTwoVectors(g_fixed, Eigen::Vector3d(0, 0, -config_.gravity))
          .toRotationMatrix();
  SE3 T_align = SE3::Identity();
  T_align.linear() = R_align;
  for (int k = 0; k < n; ++k) {
    frames[k].state.T_world_body = T_align * frames[k].state.T_world_body;
    frames[k].state.v_world = R_align * v.segment<3>(3 * k);
    frames[k].state.bg = bg;
    frames[k].state.ba.setZero();
  }
  MD_LOG(kDebug, "vio init: chain displacement "
                     << (frames.back().state.T_world_body.translation() -
                         frames.front().state.T_world_body.translation())
                            .norm()
                     << " m, first speed " << frames.front().state.v_world.norm());
  MD_LOG(kInfo, "vio initialized at t_ns=" << frames.back().features.t_ns << ": |g|=" << g.norm()
                                           << " bg=" << bg.transpose()
                                           << " speed=" << frames.back().state.v_world.norm()
                                           << " fit_rms=" << rms);
  return true;
}

std::optional<std::vector<InitFrame>> Initializer::StartAtRest() const {
  const StaticInitConfig& c = config_.static_init;
  // 1. The newest frames spanning the rest window.
  const int64_t t_now = frames_.back().features.t_ns;
  const auto window_ns = static_cast<int64_t>(std::llround(c.window_s * 1e9));
  size_t first = frames_.size() - 1;
  while (first > 0 && t_now - frames_[first].features.t_ns < window_ns) --first;
  if (t_now - frames_[first].features.t_ns < window_ns) return std::nullopt;
  // 2. Their IMU samples look like rest.
  std::vector<ImuSample> samples;
  for (size_t k = first + 1; k < frames_.size(); ++k) {
    const auto& s = frames_[k].pre.samples();
    samples.insert(samples.end(), s.begin(), s.end());
  }
  const RestCheck rest = CheckImuRest(samples, c, config_.gravity);
  if (!rest.at_rest) {
    MD_LOG(kDebug, "vio init: not at rest at t_ns=" << t_now << ": " << rest.reason);
    return std::nullopt;
  }
  // 3. Vision agrees: no frame of the window moved from the window's first (a vehicle at
  //    constant speed reads like rest to the IMU).
  const SE3& T_w_first = frames_[first].state.T_world_body;
  for (size_t k = first + 1; k < frames_.size(); ++k) {
    const SE3& T_w_k = frames_[k].state.T_world_body;
    const double moved_m = (T_w_k.translation() - T_w_first.translation()).norm();
    const double turned_deg = RotationAngle(T_w_first, T_w_k) * 180.0 / M_PI;
    if (moved_m > c.max_translation_m || turned_deg > c.max_rotation_deg) {
      MD_LOG(kDebug, "vio init: the IMU reads rest but the cameras moved " << moved_m << " m, "
                                                                           << turned_deg << " deg");
      return std::nullopt;
    }
  }
  // 4. Zero velocity, gravity opposite to the mean specific force, yaw of the first frame.
  const Eigen::Vector3d gravity_body = -rest.stats.accel_mean;
  SE3 T_world_body = SE3::Identity();
  T_world_body.linear() =
      Eigen::Quaterniond::FromTwoVectors(gravity_body, -Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  std::vector<InitFrame> out(frames_.begin() + static_cast<std::ptrdiff_t>(first), frames_.end());
  for (size_t k = 0; k < out.size(); ++k) {
    InitFrame& f = out[k];
    f.state = NavState{};
    f.state.T_world_body = T_world_body;
    f.state.bg = rest.stats.gyro_mean;
    if (k > 0) f.pre.Reintegrate(f.state.bg, Eigen::Vector3d::Zero());
  }
  MD_LOG(kInfo, "vio initialized at rest at t_ns="
                    << t_now << " (" << out.size() << " frames, " << rest.stats.samples
                    << " IMU samples): |a|=" << rest.stats.accel_mean.norm()
                    << " bg=" << rest.stats.gyro_mean.transpose() << " spread "
                    << rest.stats.gyro_std << " rad/s, " << rest.stats.accel_std << " m/s^2");
  return out;
}

}  // namespace mapdelta::vio

#pragma once
// Stage 5: pose fusion (paper section III-A-4, after VINS-Fusion's global fusion). Variables:
// T_map_body of every keyframe. Factors:
//   - odometry: relative motion between consecutive keyframes from the VIO, weighted by its
//     covariance when given, else by FusionConfig's per-step sigmas; with
//     FusionConfig::odom_scale_sigma_per_sqrt_s > 0 each keyframe also has a log scale of the
//     odometry's translation (random walk between keyframes, a prior at each segment start);
//   - global position factor  p_k^p - p_k, from each accepted registration;
//   - relative rotation factor (q_a^p)^-1 q_k^p (-) q_a^-1 q_k, from the first registered
//     keyframe a (the paper's "initial frame") to keyframe k;
//   - a prior on the first keyframe (the start-up guess);
//   - the first registration (the start-up fix: the paper assumes an accurate initial pose,
//     heading included) as a full 6-DoF pose factor; it is also the relative rotation
//     factors' reference frame a.
// Odometry resets: every keyframe carries its odometry segment (OdometrySample::segment). No
// odometry factor joins two segments; a new segment's first keyframe starts at the IMU's
// bridge across the gap when the odometry gives one (imu_gap_bridge.hpp), else at a
// constant-velocity prediction from the last fused poses, held by a pose prior with the
// bridge's covariance or the weak FusionConfig::reset_sigma_*; the segment's first accepted
// registration enters as a
// full 6-DoF pose factor (it re-anchors the segment, like the start-up fix). Re-anchoring drops
// the weak prior and re-seeds the segment's poses from the registration through the odometry.
// Registration factors use the registration covariance and a Huber loss. All covariances are
// 6x6 [rotation, translation], right perturbation T (+) d = (R Exp(w), t + R v), as GICP's.
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "mapdelta/client/config.hpp"
#include "mapdelta/client/imu_gap_bridge.hpp"
#include "mapdelta/common/pose.hpp"

namespace ceres {
class Problem;
}

namespace mapdelta::client {

using Matrix6 = Eigen::Matrix<double, 6, 6>;

struct FusionSummary {
  int iterations = 0;
  double initial_cost = 0;
  double final_cost = 0;
  double seconds = 0;
  bool usable = false;  // Ceres reported a usable solution
};

class PoseFusion {
 public:
  explicit PoseFusion(const FusionConfig& config);

  // The start-up pose of the first keyframe in the map frame and its uncertainty. Must be
  // called before the first AddKeyframe.
  void SetInitialPose(const SE3& T_map_body, const Matrix6& covariance);
  // Appends keyframe k = size(); T_odom_body is the VIO pose in its own frame; rel_covariance
  // is the covariance of the motion from the previous keyframe (right perturbation), if known.
  // The new keyframe's fused pose starts as the previous fused pose times the odometry motion.
  // A keyframe whose segment differs from the previous keyframe's starts a new segment (see
  // the header comment); rel_covariance is then ignored, and `bridge` (its pose in the
  // previous segment's odometry frame) places it if given.
  size_t AddKeyframe(int64_t t_ns, const SE3& T_odom_body,
                     const std::optional<Matrix6>& rel_covariance = std::nullopt, int segment = 0,
                     const std::optional<OdometryBridge>& bridge = std::nullopt);
  // An accepted registration of keyframe k: its measured T_map_body and covariance.
  // Throws Error(kInvalidArgument) on a bad index, pose or covariance.
  void AddRegistration(size_t k, const SE3& T_map_body, const Matrix6& covariance);

  // Solves with warm start from the current estimate (incremental runs use few iterations,
  // the final pass many). If covariance_of is given, also computes the marginal covariance of
  // those keyframes' T_map_body at the solution (6x6, [rotation, translation], right
  // perturbation) into *covariances; a keyframe whose covariance cannot be computed
  // (rank-deficient problem) gets nullopt.
  FusionSummary Optimize(int max_iterations, const std::vector<size_t>& covariance_of = {},
                         std::vector<std::optional<Matrix6>>* covariances = nullptr);

  size_t size() const { return keyframes_.size(); }
  size_t num_registrations() const { return registrations_.size(); }
  int64_t t_ns(size_t k) const { return keyframes_[k].t_ns; }
  SE3 FusedPose(size_t k) const;     // T_map_body
  SE3 OdometryPose(size_t k) const;  // T_odom_body as given
  // Odometry mapped into the map frame through the initial pose only (what the VIO alone gives);
  // after a reset, through the segment's constant-velocity start prediction.
  SE3 OdometryInMap(size_t k) const;
  int SegmentOf(size_t k) const { return keyframes_.at(k).segment; }
  // Whether keyframe k's segment has an accepted registration (is tied to the map).
  bool SegmentAnchored(size_t k) const;
  size_t num_segments() const { return segments_.size(); }
  // Whether keyframe k's segment started from an IMU bridge (its heading is known).
  bool SegmentBridged(size_t k) const { return segments_[SegmentIndex(k)].bridged; }
  // First keyframe of keyframe k's segment.
  size_t SegmentStart(size_t k) const { return segments_[SegmentIndex(k)].first_k; }
  // Index of the newest keyframe that has a registration after it (or -1).
  long LastRegisteredKeyframe() const { return last_registered_; }

 private:
  struct KeyframeState {
    int64_t t_ns = 0;
    SE3 T_odom_body = SE3::Identity();
    std::optional<Matrix6> rel_covariance;
    int segment = 0;
    double q[4] = {0, 0, 0, 1};  // T_map_body rotation, Eigen order x y z w
    double p[3] = {0, 0, 0};
    double log_scale[1] = {0};  // of the odometry step into this keyframe (scale state only)
  };
  struct Registration {
    size_t k = 0;
    SE3 T_map_body = SE3::Identity();
    Matrix6 covariance = Matrix6::Identity();
    bool segment_first = false;  // the first registration of its segment: full-pose factor
  };
  // One per odometry segment: its first keyframe, the start pose (initial guess or the
  // constant-velocity prediction) with its covariance, and whether a registration anchors it.
  struct Segment {
    int id = 0;
    size_t first_k = 0;
    SE3 T_map_body_start = SE3::Identity();
    Matrix6 covariance = Matrix6::Identity();
    bool anchored = false;
    bool bridged = false;
  };
  size_t SegmentIndex(size_t k) const;  // index into segments_ of keyframe k's segment
  SE3 PredictAcrossGap(int64_t t_ns, Matrix6* covariance) const;

  void SetState(KeyframeState* state, const SE3& T) const;
  void ComputeCovariances(ceres::Problem* problem, const std::vector<size_t>& which,
                          std::vector<std::optional<Matrix6>>* out);

  FusionConfig config_;
  bool has_initial_ = false;
  SE3 T_map_body0_ = SE3::Identity();
  Matrix6 initial_covariance_ = Matrix6::Identity();
  std::vector<KeyframeState> keyframes_;
  std::vector<Segment> segments_;
  std::vector<Registration> registrations_;
  long last_registered_ = -1;
};

// Square-root information U (U^T U = covariance^-1) for whitening residuals; throws
// Error(kInvalidArgument) if the covariance is not symmetric positive definite and finite.
Matrix6 SqrtInformation(const Matrix6& covariance);

}  // namespace mapdelta::client

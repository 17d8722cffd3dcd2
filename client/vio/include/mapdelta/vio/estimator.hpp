#pragma once
// Sliding-window stereo-inertial estimator (internal; pulls in Ceres through factors.hpp).
// The window holds up to `window_keyframes` keyframes plus, at its end, at most one
// non-keyframe (the newest frame). Per new frame:
//   1. drop the previous frame if it was not a keyframe (its IMU samples are merged into the
//      new frame's preintegration; landmarks it anchored move to their next observation);
//   2. predict the new state with the IMU, add observations, triangulate new landmarks;
//   3. optimize (IMU factors, stereo/reprojection factors on inverse depth with a robust
//      loss, marginalization prior) and remove outlier observations;
//   4. re-integrate preintegrations whose bias moved far; check for failure;
//   5. if the new frame is a keyframe and the window is full, marginalize the oldest one.
#include <Eigen/Core>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "mapdelta/vio/factors.hpp"
#include "mapdelta/vio/geometry.hpp"
#include "mapdelta/vio/initializer.hpp"
#include "mapdelta/vio/marginalization.hpp"
#include "mapdelta/vio/types.hpp"

namespace mapdelta::vio {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct EstimatorOutput {
  NavState state;  // of the newest frame
  bool keyframe = false;
  bool failed = false;                          // the caller should reset
  int landmarks = 0;                            // landmarks constraining the newest frame
  std::optional<Matrix6d> relative_covariance;  // keyframes: of T_prevkf_kf (see odometry.hpp)
  double optimize_ms = 0, marginalize_ms = 0, covariance_ms = 0;
};

struct FinalizedKeyframe {
  int64_t t_ns = 0;
  NavState state;
  std::optional<Matrix6d> relative_covariance;
};

class SlidingWindowEstimator {
 public:
  SlidingWindowEstimator(const VioConfig& config, const StereoExtrinsics& extrinsics);
  ~SlidingWindowEstimator();
  // Starts the window from an initialization; returns the newest frame's state after a first
  // joint visual-inertial solve (the linear alignment alone leaves degrees of tilt error), or
  // nothing when that solve contradicts the alignment (init_max_bias_shift_sigmas): the caller
  // then initializes again on later frames (Start clears the window first).
  std::optional<NavState> Start(std::vector<InitFrame> frames);
  EstimatorOutput AddFrame(const FrameFeatures& features, const ImuPreintegration& pre);
  // Keyframes that left the window (final estimates), oldest first; clears the list.
  std::vector<FinalizedKeyframe> TakeFinalized();
  // Moves every window keyframe to the finalized list (end of a sequence).
  void Flush();

 private:
  struct Frame {
    int64_t t_ns = 0;
    bool keyframe = true;
    double pose[7];         // p_world_body, q_world_body (x y z w)
    double sb[9];           // v_world, bg, ba
    ImuPreintegration pre;  // from the previous window frame to this one
    std::optional<Matrix6d> relative_covariance;
  };
  struct Landmark {
    std::map<int64_t, FeatureObservation> obs;  // by frame t_ns; first = anchor
    double inv_depth = 0;
    bool has_depth = false;
    // Its stereo matches are not trusted (GateByPrediction): right observations are dropped
    // and the depth comes from the left camera's motion parallax alone.
    bool left_only = false;
  };

  Frame* FindFrame(int64_t t_ns) const;
  NavState StateOf(const Frame& f) const;
  void AddObservations(const FrameFeatures& features);
  void RemoveFrameObservations(int64_t t_ns);
  // The frame's observations that contradict its (predicted) pose (prediction_gate_sigmas):
  // of a landmark that other frames confirmed, the observation is dropped (the track jumped);
  // of one only its anchor saw, the depth is forgotten and the landmark turns left_only (the
  // anchor's stereo match is the suspect), to be triangulated again at the next keyframe.
  void GateByPrediction(const Frame& frame, const FrameFeatures& features);
  void Triangulate(Landmark* lm) const;
  bool IsKeyframe(const FrameFeatures& features) const;
  // motion_only: only the newest frame's pose and speed/bias move (non-keyframes).
  void Optimize(int iterations, double max_time_s, bool motion_only = false);
  using FactorList = std::vector<std::pair<ceres::CostFunction*, std::vector<double*>>>;
  // Visual factors of a landmark (empty if it constrains no pose); caller owns them.
  void LandmarkFactors(Landmark* lm, FactorList* out) const;
  // Every factor of the window (IMU, prior, visual) for a full linearization.
  void AllFactors(FactorList* out);
  void RemoveOutliers();
  void MarginalizeOldest();
  std::optional<Matrix6d> RelativeCovariance(const Frame& a, const Frame& b);
  int LandmarksSeenIn(int64_t t_ns) const;
  Eigen::Vector3d LandmarkWorld(const Landmark& lm) const;

  VioConfig config_;
  StereoExtrinsics ext_;
  CameraExtrinsics cam0_, cam1_;
  double weight_ = 1.0;
  Eigen::Vector3d gravity_;
  std::deque<std::unique_ptr<Frame>> window_;
  std::unordered_map<uint64_t, Landmark> landmarks_;
  std::shared_ptr<Marginalizer> prior_;
  std::unique_ptr<ceres::LossFunction> loss_;
  std::vector<FinalizedKeyframe> finalized_;
};

}  // namespace mapdelta::vio

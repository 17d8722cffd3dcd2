#pragma once
// The whole vehicle pipeline over a recorded EuRoC-layout sequence, as up to five threads
// joined by bounded queues (pipeline.cpp, one function per stage):
//   0  decode and rectify frames, the odometry's front end (only for odometry that needs
//      images, with decode_ahead)                                     -> decoded queue (cap 4)
//   A  odometry, keyframe selection by motion                         -> keyframe queue (cap 4)
//   A2 SGBM depth of each keyframe                                    -> depth queue (cap 4)
//   B  (the caller's thread) temporal filter (needs i+2), local cloud every N keyframes, prior
//      registration + gate, Ceres fusion (incremental; final pass at the end), finalize
//                                                                     -> output queue (cap 16)
//   C  write the keyframe folder and enqueue uploads (durable queue)
// GICP inside B uses num_threads more. Keyframe k is final once it is final_lag_keyframes
// behind the newest and a registration at or after k was fused (its pose is then constrained
// from both sides); the rest at the end.
#include <optional>
#include <string>
#include <vector>

#include "mapdelta/client/config.hpp"
#include "mapdelta/client/odometry_source.hpp"
#include "mapdelta/client/prior_source.hpp"
#include "mapdelta/client/uploader.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta::client {

class StereoInput;

struct PipelineInputs {
  std::string sequence_dir;
  // The sequence already read and rectified by the caller (it must outlive the run), so that
  // the caller's other readers (the VIO, the upload camera) share one copy; null: read here.
  const StereoInput* input = nullptr;
  OdometrySource* odometry = nullptr;     // required
  PriorSource* prior = nullptr;           // null: no registration, fused = odometry
  Uploader* uploader = nullptr;           // null: no upload
  std::string keyframe_dir;               // keyframe folder output; empty: none
  std::optional<SE3> initial_T_map_body;  // guess at the first keyframe; null: ground truth
  int max_frames = 0;                     // 0: all frames
  int num_threads = 2;                    // for GICP
  // Decode frames (and run the odometry's PrepareFrame, the VIO's tracking) on a thread of
  // their own, ahead of the odometry. false: the odometry reads and tracks each frame on the
  // odometry thread (the structure before 2026-12-01; bench_client's baseline).
  bool decode_ahead = true;
};

// One registration attempt, for reports (registrations.csv, covariance calibration).
struct RegistrationRecord {
  int64_t t_ns = 0;
  size_t keyframe = 0;
  bool accepted = false;
  std::string reason;
  SE3 T_map_body = SE3::Identity();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
  double fitness_m = 0;
  double inlier_fraction = 0;
  size_t cloud_keyframes = 0;  // keyframes in the local cloud (more than configured if sparse)
  size_t cloud_points = 0;
};

struct StageTiming {
  std::string stage;
  double seconds = 0;
  size_t calls = 0;
};

struct PipelineResult {
  Trajectory vio_T_map_body;    // odometry mapped into the map frame by the start-up pose
  Trajectory fused_T_map_body;  // after the final pass; keyframes without a map pose omitted
  size_t frames = 0;
  size_t keyframes = 0;
  size_t registrations_accepted = 0;
  size_t registrations_rejected = 0;
  bool startup_refined = false;
  size_t odometry_resets = 0;      // odometry segment changes seen (VIO resets)
  size_t segments_reanchored = 0;  // segments after a reset re-localized by a registration
  size_t keyframes_unplaced = 0;   // keyframes of never re-anchored segments: not written/uploaded
  std::vector<RegistrationRecord> registrations;  // every attempt, in order
  std::vector<StageTiming> timing;
  double wall_seconds = 0;
};

// Throws Error for unreadable inputs; rejected registrations are logged, not thrown.
PipelineResult RunPipeline(const ClientConfig& config, const PipelineInputs& inputs);
// The camera of the keyframes RunPipeline writes and uploads: the rectified left camera without
// the stereo matcher's unmatched left band (StereoDepth::UnmatchedBandFor, CropLeftBand).
PinholeCamera KeyframeCamera(const ClientConfig& config, const PinholeCamera& left);

}  // namespace mapdelta::client

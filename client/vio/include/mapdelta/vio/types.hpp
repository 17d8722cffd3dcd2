#pragma once
// Value types and configuration shared by the VIO's stages (no Ceres/OpenCV here).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "mapdelta/common/pose.hpp"
#include "mapdelta/vio/feature_tracker_config.hpp"

namespace mapdelta::vio {

// A feature of one stereo frame in normalized image coordinates (x/z, y/z of each camera).
struct FeatureObservation {
  uint64_t id = 0;
  Eigen::Vector2d left = Eigen::Vector2d::Zero();
  bool has_right = false;
  Eigen::Vector2d right = Eigen::Vector2d::Zero();
  bool stereo_ambiguous = false;  // has_right from an ambiguous stereo search (tracker)
};

struct FrameFeatures {
  int64_t t_ns = 0;
  std::vector<FeatureObservation> features;
};

struct NavState {
  SE3 T_world_body = SE3::Identity();
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();  // gyro bias, rad/s
  Eigen::Vector3d ba = Eigen::Vector3d::Zero();  // accel bias, m/s^2
};

// Initialization at rest (rest_detector.hpp), beside the moving one: a vehicle that starts
// parked or at a light has no motion for the linear alignment to measure gravity from, but
// at rest the accelerometer reads gravity itself and the gyroscope its bias. Rest is what the
// IMU says (low spread over `window_s`) and what the stereo PnP chain confirms (the frames of
// that window did not move): a vehicle at constant speed looks at rest to an IMU.
struct StaticInitConfig {
  bool enabled = true;
  // 0.25 s: 5 frame intervals at 20 Hz, 50 IMU samples at 200 Hz (the gyro bias to about
  // 1e-3 rad/s at EuRoC's noise); real EuRoC V1_01 rests for its first ~0.3 s, then vibrates.
  double window_s = 0.25;
  // Spread over the window (norm of the per-axis standard deviations). EuRoC V1_01's first
  // 0.3 s: 0.006 rad/s and 0.09 m/s^2; with its rotors vibrating after that: 0.06 and 0.8.
  double max_gyro_std = 0.02;       // rad/s
  double max_accel_std = 0.25;      // m/s^2
  double max_gravity_error = 0.05;  // | |mean accel| - gravity | / gravity
  // Motion of the window's frames measured by the stereo PnP chain (against the window's first
  // frame): 0.02 m in 0.25 s is 8 cm/s.
  double max_translation_m = 0.02;
  double max_rotation_deg = 0.5;
};

struct VioConfig {
  TrackerConfig tracker;
  StaticInitConfig static_init;
  int window_keyframes = 10;  // keyframes kept in the optimization window
  int init_frames = 10;       // frames used by the stereo + IMU initialization
  // ... spanning at least this long: gravity comes from velocity differences over the span,
  // so its direction error scales with 1/span (tiny S2_01: 2.6 deg of tilt after 0.45 s,
  // 0.8 deg after 0.95 s).
  double init_min_span_s = 0.9;
  double init_min_disparity_px = 8.0;  // stereo points used by the initializer's PnP chain
  // ... at most this many of them, the oldest tracks first. With 300 features the extra,
  // weaker corners made the chain's positions jitter on the EuRoC-rig test (velocity fit
  // residual 0.53 m/s: initialized after 5 s instead of 1 s).
  int init_max_pnp_points = 200;
  // The initialization is refused (and retried a frame later) when the gravity it estimates
  // from the chain is further than this from `gravity` (relative), or when the velocities fit
  // the chain worse than init_max_velocity_rms_mps once gravity is fixed. |g| is the better
  // judge of a chain: the chains the paper and tiny sequences start from are within 4.5 % of
  // 9.81 (paper S1_dark small; most within 2.5 %) while paper S1_dark, big noise, seed 1 first
  // passed at 6.2 % (|g| 10.42, fit 0.44 m/s) and its VIO then drifted 2 m in 3 s before the
  // window recovered; at 5 % it starts 1 s later from a 2.0 % chain and drifts 0.35 m over the
  // same 4 s. A refused chain costs a frame or so: the next is usually in (S1_dark small: 9.2 %
  // at 1.67 s, 4.5 % at 1.70 s). The velocity residual does not separate good from bad
  // (S1_mirror big initializes well at 0.44 m/s), and a 0.25 m/s limit delayed the tiny S2_01
  // (400 px, chains fitting at 0.3-0.7 m/s) from 0.9 to 6.0 s (docs/results.md, sessions
  // 21-22).
  double init_max_gravity_error = 0.05;
  double init_max_velocity_rms_mps = 0.5;
  double pixel_sigma = 1.0;   // feature measurement noise, px
  double huber_sigmas = 1.5;  // robust loss threshold in units of pixel_sigma
  // Observations beyond this after a solve are removed. Tight, because features on
  // occlusion edges give skewed (not just wide) stereo errors that bias the scale: 4.0 left a
  // 1.2% scale error on the noiseless tiny sequence, 2.5 leaves 0.4%.
  double outlier_sigmas = 2.5;
  // Before a frame's solve, its observations of landmarks with depth that reproject further
  // than this from the IMU-predicted pose are dropped. The prediction spans one frame (mm, a
  // hundredth of a degree); a track jumping to the next window of a repetitive facade does not
  // fit it, but inside the solve a mass of such tracks pulled the pose off, and the outlier
  // step then removed the good observations instead (paper S1_02, small noise, seed 4: 258
  // observations at once, 1 landmark left, reset; with solves capped at 30 ms, 1-2 resets in 20 s).
  double prediction_gate_sigmas = 10.0;
  // Mean parallax to the last keyframe that makes a keyframe, in normalized image units
  // (0.025 = 10 px at fx = 400).
  double keyframe_parallax = 0.025;
  int keyframe_min_tracked = 40;       // fewer landmarks shared with the last keyframe: keyframe
  double keyframe_max_gap_s = 0.5;     // at most this long between keyframes
  bool right_in_other_frames = false;  // also reproject right-camera observations of
                                       // non-anchor frames (twice the visual factors)
  // Floors on the IMU noise densities: a noiseless simulation still has discretization
  // error, and zero densities would make the IMU factors infinitely stiff.
  double min_gyro_noise_density = 2e-4, min_accel_noise_density = 2e-3;
  double min_gyro_random_walk = 2e-5, min_accel_random_walk = 2e-4;
  // Prior on the accelerometer bias at (re)initialization, m/s^2.
  // While the vehicle drives straight at constant speed, accelerometer bias and tilt are not
  // separable; the window solve then drifts along that direction. With 0.2, noiseless paper
  // S2_01 moved the bias to 0.7 m/s^2 within 3 s after initialization (4 deg of tilt, 2 deg
  // of yaw error kept for good); 0.1 still drifted (0.7 deg at 8 s); 0.05 held the tilt at
  // 0.1 deg. Real MEMS turn-on biases can be larger: lower it only with calibrated IMUs.
  double init_accel_bias_sigma = 0.05;
  double init_gyro_bias_sigma = 0.02;  // rad/s; the alignment estimates it from the rotations
  // Reject an initialization whose first joint solve moves the biases away from the
  // alignment's (gyro) and from zero (accelerometer) by more than this many sigmas (the root of
  // the six components' squared normalized shifts). A window the alignment got wrong can only
  // be fitted by absorbing the error into the biases: paper S1_02, small noise, seed 2
  // initialized with |g| 10.75 from a noisy PnP chain, and the first solve moved bg_z from
  // 0.002 to 0.094 rad/s and ba_z to -0.38 m/s^2 (9 sigmas); the yaw then drifted 5 deg/s
  // until the window lost its landmarks. Rejected, the initializer retries on later frames.
  double init_max_bias_shift_sigmas = 4.0;
  // Keep position and yaw (the unobservable gauge) out of the marginalization prior and hold
  // them with an anchor on the window's oldest frame (gauge.hpp says why).
  bool gauge_free_prior = true;
  int solver_iterations = 6;
  // Speed (bench/bench_vio): closed-form reprojection Jacobians instead of autodiff, and
  // for non-keyframes a motion-only solve of the newest state instead of the whole window
  // (depths are triangulated on keyframes only: triangulating from the predicted pose and
  // then holding the depth fixed had made it diverge). On: it pays for the 300 features
  // (noiseless paper S2_02: 200 features with full solves 162 s CPU, ATE 0.620 m; 300 with
  // full solves 208 s, 0.142 m; 300 motion-only 149 s, 0.217 m).
  bool analytic_reprojection = true;
  bool motion_only_non_keyframes = true;
  int init_solver_iterations = 30;      // first solve after initialization (converged)
  double init_solver_max_time_s = 1.5;  // a one-off stall at (re)initialization
  double solver_max_time_s = 0.08;
  int solver_threads = 1;
  bool compute_keyframe_covariance = true;
  double gravity = 9.81;  // m/s^2, along -z of the odometry world frame
  // Failure detection (reset) thresholds.
  double max_accel_bias = 2.0;  // m/s^2
  double max_gyro_bias = 0.5;   // rad/s
  double max_speed = 60.0;      // m/s
  int min_landmarks = 10;       // landmarks constraining the newest frame
};

}  // namespace mapdelta::vio

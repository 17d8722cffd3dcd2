#pragma once
// Configuration of every client stage: nested structs with defaults and units in the
// declaration (defaults from shared/DESIGN.md and the paper's reference config). Loaded from
// YAML in one place (src/config.cpp lists every field with its range); unknown keys and
// out-of-range values are all reported at once.
#include <string>

namespace mapdelta::client {

struct StereoConfig {
  int num_disparities = 128;  // at reference_width; scaled with the image width
  int reference_width = 800;  // width num_disparities refers to (the paper's camera)
  int min_disparity = 0;
  int block_size = 5;             // odd, pixels
  int uniqueness_ratio = 10;      // percent margin of the best over the second-best cost
  int disp12_max_diff = 1;        // left-right consistency tolerance, pixels
  int speckle_window_size = 100;  // pixels; 0 disables speckle filtering
  int speckle_range = 2;          // disparity variation inside a speckle, pixels
  int pre_filter_cap = 63;
  double max_depth_m = 50.0;  // depths beyond this are dropped
  // Gaussian smoothing of both images before matching (common image_noise.hpp DenoiseSigmaFor):
  // < 0 = sized from each keyframe's measured image noise (none on a clean camera), 0 = off,
  // > 0 = this sigma in pixels; either at reference_width, scaled with the image width.
  double denoise_sigma_px = -1.0;
};

struct TemporalFilterConfig {
  int half_window = 2;     // keyframes i-2..i+2
  double delta_d_m = 0.5;  // a projection succeeds if depths differ by less than this
  // Keep pixels with at least alpha successful projections, for the depth written and uploaded.
  // The paper uses 4; 3 is our default (client/README.md "Temporal filter density"): on the
  // main job's sim S1_01 / S2_01 with the VIO, change detection P_new / P_rm / R_new was
  // 0.99 / 0.41 / 0.89 and 0.99 / 0.27 / 0.95 with alpha 4, 0.53 / 0.93 / 1.00 and
  // 0.58 / 0.75 / 0.98 with 2, 0.90 / 0.80 / 0.96 and 0.91 / 0.59 / 0.99 with 3.
  int alpha = 3;
  // The local clouds registered to the prior use their own, stricter alpha (the paper's 4):
  // precise points matter more there than density (5-keyframe start-up fixture: 0.47 m error
  // with alpha 2 vs 0.38 m with 4). Equal to alpha: one filter pass.
  int registration_alpha = 4;
};

struct KeyframeSelectionConfig {
  double min_translation_m = 1.0;  // a new keyframe after this much motion ...
  double min_rotation_deg = 10.0;  // ... or this much rotation ...
  double max_interval_s = 1.0;     // ... or this much time
};

struct LocalCloudConfig {
  int keyframes = 5;  // keyframes aggregated into one local cloud
  // A local cloud is registered every this many keyframes (0 = `keyframes`: clouds do not
  // overlap).
  int every_keyframes = 0;
  // Sparse depth (a dark scene, a blank wall) leaves a 5-keyframe cloud too few points for the
  // registration gate's inlier floor: below min_points the cloud grows back over earlier
  // keyframes of the same odometry segment, `keyframes` at a time, up to max_keyframes (kept
  // under fusion.final_lag_keyframes, so they are still buffered). Measured on the paper preset,
  // seed 1: S1_dark big has 5-keyframe clouds of 15/98/273 points (10th/50th/90th percentile)
  // and 46 of 128 registrations rejected, 4 with growth; S1_01 small's smallest cloud has 734
  // points, so there it never grows (docs/results.md, issue 21).
  int min_points = 400;
  int max_keyframes = 20;
  double voxel_m = 0.4;
  double max_depth_m = 50.0;
  int pixel_stride = 2;  // sample every n-th pixel (the voxel grid averages anyway)
};

struct RegistrationConfig {
  double max_fitness_m = 1.0;        // gate: mean nearest-neighbour distance
  double max_correction_m = 4.0;     // gate: translation between guess and result
  double max_correction_deg = 10.0;  // gate: rotation between guess and result
  double max_correspondence_m = 2.0;
  int max_iterations = 50;
  double prior_radius_m = 100.0;  // prior fetched around the vehicle
  double prior_voxel_m = 0.4;
  // Multiplies the registration covariance before fusion. GICP's sandwich covariance is
  // calibrated for independent point noise; stereo local clouds carry correlated errors
  // (depth bias, odometry inside the cloud). Measured against ground truth on the simulator
  // (docs/registration.md): factor for 97% of per-axis errors within 3 sigma 5-7 (tiny S1/S2,
  // drift odometry), 15.5 (paper S1_01, 127 registrations), 20 (tiny S1_01, VIO); 16 gives
  // 98-99% on tiny drift runs and lowers the fused ATE (0.122/0.152 -> 0.104/0.115 m).
  double covariance_scale = 16.0;
  // GICP's covariance shrinks as 1 / N with N inlier points, the errors of a stereo local cloud
  // (depth bias, odometry inside the cloud) do not: beyond this many inliers the covariance is
  // scaled up by N / covariance_full_points, as if the cloud had only this many. Measured on
  // paper S2_01 small, seed 2: denoised depth raised the clouds from 2300 to 4000 points on
  // average at the same error (0.116 vs 0.111 m rms), and its registrations' error over sigma
  // along track from 1.0 to 1.7, so the fusion trusted them too much (fused ATE 0.059 -> 0.075
  // m). 2000 is about the clouds the covariance_scale above was measured with.
  double covariance_full_points = 2000.0;
  bool source_as_points = false;  // GicpParams::source_as_points
  // Second-minimum check of every accepted registration (PriorRegistrar): GICP from the result
  // shifted +-ambiguity_probe_m along the body's x and y; a different pose fitting the prior
  // nearly as well (share of points within max_fitness_m / 2 >= ambiguity_probe_ratio of the
  // result's) raises the variance along that axis to the separation squared. 0: off.
  // Measured on paper S1_dark, big noise, seed 1 (docs/results.md, issue 21, session 21): the
  // share of along-track errors within 3 sigma 0.89 -> 0.95-0.98, fused ATE 0.292 -> 0.274
  // and 0.244 -> 0.240 m (two pairs of runs); registration 209 -> 289 ms per call.
  double ambiguity_probe_m = 1.0;
  double ambiguity_probe_ratio = 0.9;
  // After this many rejections in a row the vehicle re-localizes like at start-up:
  // coarse-to-fine registration accepting corrections up to the limits below.
  int relocalize_after_rejections = 2;
  double relocalize_max_correction_m = 8.0;
  double relocalize_max_correction_deg = 15.0;
  // Re-anchoring after an odometry reset tries the segment start at the constant-velocity
  // prediction and at the last fused pose (stopped), each turned by this many evenly spaced
  // headings (the new VIO frame's yaw is arbitrary and the vehicle may have turned or
  // reversed during the gap); the relocalize_* limits apply around each hypothesis.
  int reanchor_yaw_hypotheses = 12;
  // Registrations tilted against a gravity-aligned odometry's (the VIO's) gravity by more
  // than this are rejected (RegistrationGate::source_up). 180 turns the check off.
  double max_tilt_deg = 6.0;
};

struct FusionConfig {
  double odom_sigma_rot_rad = 0.002;     // per keyframe step, when the VIO gives no covariance
  double odom_sigma_trans_m = 0.02;      // per keyframe step ...
  double odom_sigma_trans_per_m = 0.01;  // ... plus this fraction of the step length
  double huber_delta = 2.0;              // robust loss, in whitened (sigma) units
  // The odometry's translation scale as a slowly varying state: each keyframe's log scale
  // (random walk, this sigma per sqrt(s); 0 = no scale state) multiplies the step into it,
  // starting at 0 with odom_scale_sigma at each segment's first keyframe.
  double odom_scale_sigma_per_sqrt_s = 0.0;
  double odom_scale_sigma = 0.1;
  int incremental_iterations = 10;
  int final_iterations = 100;
  int final_lag_keyframes = 30;     // keyframes this far behind the newest are final
  double init_sigma_rot_rad = 0.1;  // prior on the first pose (start-up guess, refined)
  double init_sigma_trans_m = 2.0;
  // After an odometry reset the new segment's first keyframe is predicted at constant velocity
  // from the last fused poses; the prediction enters as a weak pose prior with these sigmas
  // (base + growth per second of odometry gap) until a registration re-anchors the segment.
  double reset_sigma_rot_rad = 0.1;
  double reset_sigma_rot_per_s = 0.1;
  double reset_sigma_trans_m = 2.0;
  double reset_sigma_trans_per_s = 2.0;
};

struct UploadConfig {
  std::string vehicle_id = "vehicle";
  double retry_initial_s = 0.2;
  double retry_max_s = 10.0;
  double timeout_s = 10.0;  // per request
  // Stop with an error after failing this long without one successful answer (a dead or
  // unreachable server); the queue keeps everything for the next run. 0 = retry forever.
  double give_up_after_s = 300.0;
  double depth_scale = 1000.0;
};

// The VIO (--odometry vio), what the client sets of its vio::VioConfig.
struct VioSettings {
  // Gaussian smoothing of both images before the front end's corners and tracks
  // (vio::TrackerConfig::smooth_sigma_px): -1 = sized by each frame's measured noise as the
  // stereo depth's denoise_sigma_px -1, from 8 grey levels of noise on (the big-noise
  // simulator: 2 px); 0 = off; > 0 = this sigma in pixels.
  double smooth_sigma_px = -1.0;
};

struct ClientConfig {
  VioSettings vio;
  StereoConfig stereo;
  TemporalFilterConfig temporal_filter;
  KeyframeSelectionConfig keyframes;
  LocalCloudConfig local_cloud;
  RegistrationConfig registration;
  FusionConfig fusion;
  UploadConfig upload;
};

// Reads a YAML file whose top-level keys are the sections above (all optional), with common's
// strict reader (config_reader.hpp): throws Error(kInvalidArgument) listing every unknown key,
// wrong type and out-of-range value in one message (a config error: exit code 2).
ClientConfig LoadClientConfig(const std::string& path);
ClientConfig ParseClientConfig(const std::string& yaml_text, const std::string& what);
// The effective configuration as YAML (loadable by LoadClientConfig).
std::string ToYaml(const ClientConfig& config);

}  // namespace mapdelta::client

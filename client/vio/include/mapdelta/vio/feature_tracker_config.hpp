#pragma once
// Front-end settings (kept apart from feature_tracker.hpp so it needs no OpenCV).
namespace mapdelta::vio {

struct TrackerConfig {
  // 300 instead of 200 (session 5): noiseless paper S2_02 (15 m height) 0.620 -> 0.142 m ATE,
  // the yaw drift 1.0 -> 0.4 deg; 250 gave 0.536 m. Paid for by the motion-only solve of
  // non-keyframes (types.hpp).
  int max_features = 300;
  double min_distance_px = 20.0;
  double corner_quality = 0.005;
  int klt_window_px = 21;
  int klt_levels = 3;
  double forward_backward_px = 0.5;  // max round-trip error of a KLT track
  double ransac_px = 1.0;            // fundamental-matrix RANSAC threshold
  double stereo_row_px = 1.5;        // max |v_right - v_left| on a rectified pair
  double max_disparity_px = 256.0;
  double min_zncc = 0.7;  // coarse stereo match acceptance
  // A stereo match whose ZNCC peak beats every other more than 2 px away by less than this is
  // ambiguous (TrackedFeature::stereo_ambiguous; 0 = never): on repeated windows the best peak
  // alone takes a wrong period. The initializer's PnP chain then leaves such points out while
  // 30 others remain; the estimator keeps them (its robust loss sees them over a window).
  // Measured against the ground-truth motion (paper preset, the first frame's stereo points,
  // the depth the track implies 1 s later off by more than 1.5x): S1_02 small 53 of 216 such
  // gross errors, S1_01 big 18 of 108, S1_dark small 17 of 62; none, 2 and 6 among the matches
  // 0.05 leaves unambiguous. With 0.05, bench_vio: S1_02 small seed 1 first pose 14.1 -> 1.0 s
  // (its chains failed the init checks for 14 s), 25 s ATE 0.099 -> 0.070 m; S1_dark big 40 s
  // 0.224 -> 0.227 m, S1_dark small 0.243 -> 0.248 m. Off by default: on the 11 cm EuRoC
  // geometry (VioSim.EurocCameraGeometrySequence) the unambiguous chain never passed the init
  // checks. Dropping ambiguous matches outright instead cut S1_dark big's stereo points by 40 %
  // and raised its 40 s VIO error to 0.28 m (docs/results.md, session 26). 0.02 (session 27,
  // bench_vio): the EuRoC geometry starts at 0.9 s as with 0 (0.05: no pose in 5 s), S1_02 small
  // seed 1 at 0.9 s (20 s ATE 0.096 -> 0.053 m), but the 40 s VIO error of S1_dark big 0.225 ->
  // 0.237 m and S1_01 big seed 4 0.118 -> 0.126 m: kept off until a full table run decides.
  double stereo_min_margin = 0.0;
  // Bounded cost (issue 25: real textures made the front end 3-4x slower than simulated ones).
  // Corners are looked for only in the cells of this grid that hold fewer than their share of
  // max_features and lost features since their last search (tracks ran out there), or, if
  // under their share, every detect_retry_frames frames (staggered); among those cells the
  // strongest corners first, as goodFeaturesToTrack.
  int grid_cols = 8, grid_rows = 5;
  // 1, not 5: on the paper's dark scene (S1_dark, big noise, seed 1; tracks live 2.6 frames)
  // waiting 5 frames to search a cell that had no corner starved the estimator (9 landmarks) and
  // reset the VIO at 54 s in every run (ATE 38 m), where every frame gives 1.07 m and no reset
  // (the binary before the grid: 1.66 m). Cost on the real EuRoC excerpt: front end 13.3-14.6
  // -> 16.8-16.9 ms/frame (2 runs each, beside another run), still bounded by the cells.
  int detect_retry_frames = 1;
  // Full-range stereo searches of unmatched tracks per frame (new features always get one);
  // with more unmatched tracks each waits its turn (staggered by id).
  int stereo_full_searches = 100;
  // Stereo KLT refinement from the ZNCC guess: pyramid levels above the base and iterations.
  // One level and 30 iterations as before: the base level with 10 iterations raised the 90th
  // percentile of the disparity error on the simulated EuRoC rig from 0.59 to 0.83 px
  // (test VioEurocRig.SimulatedMh01SensorsSequence).
  int stereo_klt_levels = 1;
  int stereo_klt_iterations = 30;
  // The temporal forward-backward check (back from the tracked point, starting at the
  // original): pyramid levels above the base and iterations.
  int back_check_levels = 0;
  int back_check_iterations = 30;
  // Gaussian smoothing of both images before detection and tracking: -1 = sized by each left
  // image's measured noise (common image_noise.hpp, the rule the client's stereo depth uses:
  // 0.5 px per grey level above 2, at most 2 px, at 800 px scaled with the width), but only
  // from kSmoothingMinNoise grey levels on; 0 = off; > 0 = this sigma in pixels. Corners
  // picked on raw, very noisy pixels are noise peaks that do not track: on the paper's dark
  // scene with big noise (10 grey levels, 2 px) the VIO's scale over 5 s windows went from
  // 0.965-1.030 to 0.984-1.008 (5th-95th percentile) and the fused ATE from 0.22 to 0.11 m
  // (docs/results.md, session 24). With the small-noise preset (5.2 grey levels, 1.5 px on
  // EuRoC's 752 px camera and 11 cm baseline) the VIO did not initialize in
  // VioSim.EurocCameraGeometrySequence, hence the floor; real EuRoC (1.7) is never smoothed.
  double smooth_sigma_px = -1.0;
};
// The width smooth_sigma_px -1 sizes the smoothing at (the paper's camera), and the noise (grey
// levels) from which it smooths at all.
inline constexpr double kSmoothingReferenceWidth = 800.0;
inline constexpr double kSmoothingMinNoise = 8.0;

}  // namespace mapdelta::vio

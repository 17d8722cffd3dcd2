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
};

}  // namespace mapdelta::vio

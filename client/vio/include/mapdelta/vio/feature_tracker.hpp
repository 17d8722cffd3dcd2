#pragma once
// Stereo KLT front end on rectified image pairs (internal: OpenCV types in the interface; only
// the VIO's own sources include this header).
//   1. track last frame's left features with pyramidal KLT, keep those passing a
//      forward-backward check, then reject outliers with a fundamental-matrix RANSAC;
//   2. detect new Shi-Tomasi corners at least `min_distance_px` from every kept feature, only in
//      the grid cells holding fewer than their share of features;
//   3. match each left feature in the right image: ZNCC search along the same row for the
//      coarse disparity, KLT refinement, row check (rectified: |v_r - v_l| small) and a
//      right-to-left KLT consistency check.
#include <opencv2/core.hpp>

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "mapdelta/vio/feature_tracker_config.hpp"

namespace mapdelta::vio {

struct TrackedFeature {
  uint64_t id = 0;
  Eigen::Vector2d left_px;
  bool has_right = false;
  Eigen::Vector2d right_px = Eigen::Vector2d::Zero();
  int track_count = 1;  // frames this feature has been seen in, including this one
  // has_right, but another disparity scored almost as well (TrackerConfig::stereo_min_margin).
  bool stereo_ambiguous = false;
};

struct TrackerStats {
  int tracked = 0, rejected_fb = 0, rejected_ransac = 0, detected = 0, stereo = 0;
  int cells_searched = 0;      // grid cells where corners were looked for
  int stereo_deferred = 0;     // unmatched tracks whose full stereo search waits (retry schedule)
  double smooth_sigma_px = 0;  // Gaussian smoothing applied to this frame (0: none)
};

class FeatureTracker {
 public:
  explicit FeatureTracker(const TrackerConfig& config = {}) : config_(config) {}
  // `left`, `right`: 8-bit single-channel rectified images of equal size.
  std::vector<TrackedFeature> Track(const cv::Mat& left, const cv::Mat& right);
  const TrackerStats& last_stats() const { return stats_; }
  void Reset();

 private:
  // TrackerConfig::smooth_sigma_px for this frame (sized by its noise when -1).
  double SmoothingSigma(const cv::Mat& left) const;
  void TrackTemporal(const cv::Mat& left);
  void Detect(const cv::Mat& left);
  void MatchStereo(const cv::Mat& left, const cv::Mat& right);

  TrackerConfig config_;
  TrackerStats stats_;
  // KLT image pyramids with their derivatives, built once per image: calcOpticalFlowPyrLK on
  // plain images rebuilds both pyramids and the derivatives in each of its four calls per frame.
  std::vector<cv::Mat> prev_pyramid_, left_pyramid_, right_pyramid_;
  std::vector<cv::Point2f> points_;
  std::vector<uint64_t> ids_;
  std::vector<int> counts_;
  std::vector<float> disparity_;          // last stereo disparity per feature, < 0 if none
  std::vector<unsigned char> ambiguous_;  // its full stereo search was ambiguous
  std::vector<cv::Point2f> right_points_;
  std::vector<unsigned char> has_right_;
  uint64_t next_id_ = 1;
  uint64_t frame_ = 0;  // frames tracked, for the stereo retry schedule
  // Per grid cell, from its last search: the strongest corner away from features, and the
  // features it then held (-1: not searched yet).
  std::vector<float> cell_max_;
  std::vector<int> cell_kept_;
};

}  // namespace mapdelta::vio

#include "mapdelta/vio/feature_tracker.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>

#include "mapdelta/common/image_noise.hpp"
#include "mapdelta/vio/row_zncc.hpp"

namespace mapdelta::vio {
namespace {

constexpr int kBorder = 8;

bool Inside(const cv::Point2f& p, const cv::Mat& image) {
  return p.x >= kBorder && p.y >= kBorder && p.x < image.cols - kBorder &&
         p.y < image.rows - kBorder;
}

template <typename T>
void Compact(std::vector<T>* v, const std::vector<unsigned char>& keep) {
  size_t j = 0;
  for (size_t i = 0; i < v->size(); ++i) {
    if (keep[i]) (*v)[j++] = (*v)[i];
  }
  v->resize(j);
}

}  // namespace

void FeatureTracker::Reset() {
  prev_pyramid_.clear();
  cell_max_.clear();
  cell_kept_.clear();
  points_.clear();
  ids_.clear();
  counts_.clear();
  disparity_.clear();
  ambiguous_.clear();
}

double FeatureTracker::SmoothingSigma(const cv::Mat& left) const {
  if (config_.smooth_sigma_px >= 0) return config_.smooth_sigma_px;
  if (left.type() != CV_8UC1) return 0.0;
  const double noise = EstimateImageNoise(left.cols, left.rows, left.step[0], left.data);
  if (noise < kSmoothingMinNoise) return 0.0;
  return DenoiseSigmaFor(noise) * left.cols / kSmoothingReferenceWidth;
}

std::vector<TrackedFeature> FeatureTracker::Track(const cv::Mat& left_in, const cv::Mat& right_in) {
  stats_ = {};
  cv::Mat left = left_in, right = right_in;
  const double sigma = SmoothingSigma(left_in);
  stats_.smooth_sigma_px = sigma;
  if (sigma > 0) {
    cv::GaussianBlur(left_in, left, cv::Size(), sigma);
    cv::GaussianBlur(right_in, right, cv::Size(), sigma);
  }
  const cv::Size window(config_.klt_window_px, config_.klt_window_px);
  // Padded copies (tryReuseInputImage = false), never views of the caller's images: the left
  // pyramid is kept as the next frame's previous one.
  cv::buildOpticalFlowPyramid(left, left_pyramid_, window, config_.klt_levels, true,
                              cv::BORDER_REFLECT_101, cv::BORDER_CONSTANT, false);
  cv::buildOpticalFlowPyramid(right, right_pyramid_, window, config_.stereo_klt_levels, true,
                              cv::BORDER_REFLECT_101, cv::BORDER_CONSTANT,
                              false);  // only the levels the stereo KLT uses
  if (!prev_pyramid_.empty() && !points_.empty()) TrackTemporal(left);
  Detect(left);
  MatchStereo(left, right);
  std::swap(prev_pyramid_, left_pyramid_);
  ++frame_;
  std::vector<TrackedFeature> out(points_.size());
  for (size_t i = 0; i < points_.size(); ++i) {
    out[i].id = ids_[i];
    out[i].left_px = {points_[i].x, points_[i].y};
    out[i].has_right = has_right_[i] != 0;
    out[i].right_px = {right_points_[i].x, right_points_[i].y};
    out[i].track_count = counts_[i];
    out[i].stereo_ambiguous = has_right_[i] != 0 && ambiguous_[i] != 0;
  }
  return out;
}

void FeatureTracker::TrackTemporal(const cv::Mat& left) {
  const cv::Size window(config_.klt_window_px, config_.klt_window_px);
  std::vector<cv::Point2f> next, back;
  std::vector<unsigned char> status, status_back;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(prev_pyramid_, left_pyramid_, points_, next, status, err, window,
                           config_.klt_levels);
  // The way back starts at the original points, so it is a check that they are where the
  // track leads back to, not a second search: the base level with a few iterations suffices
  // (the coarse levels were a third of the front end's KLT time on real frames).
  back = points_;
  const cv::TermCriteria back_stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                   config_.back_check_iterations, 0.01);
  cv::calcOpticalFlowPyrLK(left_pyramid_, prev_pyramid_, next, back, status_back, err, window,
                           config_.back_check_levels, back_stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<unsigned char> keep(points_.size(), 0);
  for (size_t i = 0; i < points_.size(); ++i) {
    const float fb = std::hypot(back[i].x - points_[i].x, back[i].y - points_[i].y);
    keep[i] =
        status[i] && status_back[i] && fb <= config_.forward_backward_px && Inside(next[i], left);
    if (!keep[i]) ++stats_.rejected_fb;
  }
  std::vector<cv::Point2f> prev = points_;
  points_ = next;
  Compact(&prev, keep);
  Compact(&points_, keep);
  Compact(&ids_, keep);
  Compact(&counts_, keep);
  Compact(&disparity_, keep);
  Compact(&ambiguous_, keep);
  // Outliers that KLT tracked consistently but onto the wrong structure (e.g. occlusion
  // boundaries) violate the epipolar geometry of the frame pair.
  if (points_.size() >= 16) {
    std::vector<unsigned char> inliers;
    cv::findFundamentalMat(prev, points_, cv::FM_RANSAC, config_.ransac_px, 0.99, inliers);
    if (inliers.size() == points_.size()) {
      for (unsigned char in : inliers) stats_.rejected_ransac += in ? 0 : 1;
      Compact(&points_, inliers);
      Compact(&ids_, inliers);
      Compact(&counts_, inliers);
      Compact(&disparity_, inliers);
      Compact(&ambiguous_, inliers);
    }
  }
  for (int& c : counts_) ++c;
  stats_.tracked = static_cast<int>(points_.size());
}

void FeatureTracker::Detect(const cv::Mat& left) {
  const int wanted = config_.max_features - static_cast<int>(points_.size());
  const int cols = std::max(1, config_.grid_cols), rows = std::max(1, config_.grid_rows);
  const size_t cells = static_cast<size_t>(cols * rows);
  if (cell_max_.size() != cells) {  // first frame (or after a reset): every cell is searched
    cell_max_.assign(cells, 0.f);
    cell_kept_.assign(cells, -1);
  }
  if (wanted <= 0) return;
  const int quota = (config_.max_features + static_cast<int>(cells) - 1) / static_cast<int>(cells);
  auto cell_rect = [&](size_t c) {
    const int cx = static_cast<int>(c) % cols, cy = static_cast<int>(c) / cols;
    const int x0 = cx * left.cols / cols, x1 = (cx + 1) * left.cols / cols;
    const int y0 = cy * left.rows / rows, y1 = (cy + 1) * left.rows / rows;
    return cv::Rect(x0, y0, x1 - x0, y1 - y0);
  };
  std::vector<int> count(cells, 0);
  for (const auto& p : points_) {
    const int cx = std::clamp(static_cast<int>(p.x) * cols / left.cols, 0, cols - 1);
    const int cy = std::clamp(static_cast<int>(p.y) * rows / left.rows, 0, rows - 1);
    ++count[static_cast<size_t>(cy * cols + cx)];
  }
  // Searched: the cells under their share that lost features since their last search (tracks
  // ran out there) or whose turn it is (every detect_retry_frames frames, staggered), e.g. to
  // take corners that came into view. A full cell or one that keeps what it had waits: the
  // cost follows the features to replace, not the image's texture.
  const int retry = std::max(1, config_.detect_retry_frames);
  std::vector<size_t> open;
  for (size_t c = 0; c < cells; ++c) {
    if (count[c] >= quota) continue;
    if (count[c] < cell_kept_[c] || (frame_ + c) % static_cast<uint64_t>(retry) == 0 ||
        cell_kept_[c] < 0)
      open.push_back(c);
  }
  if (open.empty()) return;
  cv::Mat mask(left.size(), CV_8UC1, cv::Scalar(255));
  const int radius = static_cast<int>(config_.min_distance_px);
  for (const auto& p : points_) cv::circle(mask, p, radius, cv::Scalar(0), cv::FILLED);
  // Corner strength (the minimum eigenvalue, as goodFeaturesToTrack) in the open cells, on views
  // of the image (the filters read the pixels around a cell, not a mirrored edge). As in
  // goodFeaturesToTrack with a mask, the threshold is relative to the strongest corner where
  // new features may go; cells not searched now count with their value from their last search.
  std::vector<cv::Mat> strength(cells);
  for (size_t c : open) {
    const cv::Rect r = cell_rect(c);
    cv::Mat& eig = strength[c];
    cv::cornerMinEigenVal(left(r), eig, 3, 3);
    double max_value = 0;
    cv::minMaxLoc(eig, nullptr, &max_value, nullptr, nullptr, mask(r));
    cell_max_[c] = static_cast<float>(max_value);
  }
  const float threshold = static_cast<float>(config_.corner_quality) *
                          *std::max_element(cell_max_.begin(), cell_max_.end());
  struct Candidate {
    float score;
    cv::Point2f p;
    size_t cell;
  };
  std::vector<Candidate> candidates;
  for (size_t c : open) {
    const cv::Rect r = cell_rect(c);
    const cv::Mat& eig = strength[c];
    cv::Mat peaks;
    cv::dilate(eig, peaks, cv::Mat());  // 3x3 local maxima, as goodFeaturesToTrack
    for (int y = 0; y < eig.rows; ++y) {
      const float* e = eig.ptr<float>(y);
      const float* d = peaks.ptr<float>(y);
      const uint8_t* m = mask.ptr<uint8_t>(r.y + y) + r.x;
      for (int x = 0; x < eig.cols; ++x) {
        if (e[x] > threshold && e[x] == d[x] && m[x]) {
          const cv::Point2f p(static_cast<float>(r.x + x), static_cast<float>(r.y + y));
          candidates.push_back({e[x], p, c});
        }
      }
    }
  }
  // The strongest first, min_distance apart, as goodFeaturesToTrack does on the whole image:
  // the grid decides where to look, not a share per cell (a per-cell share put weak corners of
  // poor cells before strong ones and shortened the tracks on the simulator: README).
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  // Corners in the border strip take their place and keep others min_distance away but are not
  // kept (as goodFeaturesToTrack's output filtered by Inside() did): admitting the next corner
  // instead put short-lived features at the image edge (tracks 6.1 -> 5.2 frames on tiny S1_01).
  std::vector<Candidate> chosen;
  int taken = 0;
  for (const Candidate& k : candidates) {
    if (taken >= wanted) break;
    if (!mask.at<uint8_t>(cv::Point(k.p))) continue;  // too close to a feature or one chosen
    cv::circle(mask, k.p, radius, cv::Scalar(0), cv::FILLED);
    ++taken;
    if (Inside(k.p, left)) chosen.push_back(k);
  }
  for (size_t c : open) cell_kept_[c] = count[c];
  for (const Candidate& k : chosen) ++cell_kept_[k.cell];
  for (const Candidate& k : chosen) {
    points_.push_back(k.p);
    ids_.push_back(next_id_++);
    counts_.push_back(1);
    disparity_.push_back(-1.f);
    ambiguous_.push_back(0);
    ++stats_.detected;
  }
  stats_.cells_searched = static_cast<int>(open.size());
}

void FeatureTracker::MatchStereo(const cv::Mat& left, const cv::Mat& right) {
  const size_t n = points_.size();
  right_points_.assign(n, cv::Point2f(0, 0));
  has_right_.assign(n, 0);
  std::vector<float> last_disparity = disparity_;
  disparity_.assign(n, -1.f);
  if (n == 0) return;
  // Unmatched tracks (no disparity, seen before) share the full-search budget.
  size_t unmatched = 0;
  for (size_t i = 0; i < n; ++i) unmatched += last_disparity[i] < 0 && counts_[i] > 1 ? 1 : 0;
  const size_t budget = static_cast<size_t>(std::max(1, config_.stereo_full_searches));
  const uint64_t retry_period = (unmatched + budget - 1) / budget;
  // 1. Coarse disparity by ZNCC along the row (large baselines defeat plain KLT).
  constexpr int kHalf = 5;
  std::vector<cv::Point2f> guess(n), candidates;
  std::vector<size_t> index;
  std::vector<float> scores;
  for (size_t i = 0; i < n; ++i) {
    const int u = static_cast<int>(std::lround(points_[i].x));
    const int v = static_cast<int>(std::lround(points_[i].y));
    if (u - kHalf < 0 || v - kHalf < 0 || u + kHalf >= left.cols || v + kHalf >= left.rows)
      continue;
    // A band around the last disparity for matched features; all disparities for new ones and
    // for unmatched tracks, the latter at most stereo_full_searches per frame (staggered by id
    // when there are more): on real frames about half of the features find no right match
    // (occluded, outside the right image, weak) and searching them all on every frame was
    // most of the front end's cost.
    int d_min = 0, d_max = static_cast<int>(config_.max_disparity_px);
    if (last_disparity[i] >= 0) {
      d_min = std::max(0, static_cast<int>(last_disparity[i]) - 12);
      d_max = std::min(d_max, static_cast<int>(last_disparity[i]) + 12);
    } else if (counts_[i] > 1 && retry_period > 1 && (frame_ + ids_[i]) % retry_period != 0) {
      ++stats_.stereo_deferred;
      continue;
    }
    const int x0 = std::max(0, u - d_max - kHalf);
    const int x1 = u - d_min + kHalf + 1;
    if (x1 - x0 < 2 * kHalf + 1 || x1 > right.cols) continue;
    // Right patches centred at x0 + kHalf .. x1 - 1 - kHalf; score k is centre x0 + kHalf + k.
    RowZncc(left, right, u, v, kHalf, x0 + kHalf, x1 - 1 - kHalf, &scores);
    const int at =
        static_cast<int>(std::max_element(scores.begin(), scores.end()) - scores.begin());
    if (!(scores[static_cast<size_t>(at)] >= config_.min_zncc)) continue;
    // With a margin, a full search decides whether the match is ambiguous; a band search keeps the
    // verdict of the full search the track's disparity came from (a wrong period looks unique in
    // the band).
    if (config_.stereo_min_margin > 0 && last_disparity[i] < 0) {
      float second = -1.f;
      for (int k = 0; k < static_cast<int>(scores.size()); ++k) {
        if (std::abs(k - at) > 2) second = std::max(second, scores[static_cast<size_t>(k)]);
      }
      ambiguous_[i] = scores[static_cast<size_t>(at)] - second < config_.stereo_min_margin;
    }
    // Sub-pixel peak by a parabola through the neighbours.
    double dx = 0;
    if (at > 0 && at + 1 < static_cast<int>(scores.size())) {
      const float l = scores[static_cast<size_t>(at - 1)], c = scores[static_cast<size_t>(at)],
                  r = scores[static_cast<size_t>(at + 1)];
      const double denom = l - 2 * c + r;
      if (std::abs(denom) > 1e-9) dx = std::clamp(0.5 * (l - r) / denom, -0.5, 0.5);
    }
    const double x_right = x0 + at + dx + kHalf + (points_[i].x - u);
    guess[i] = cv::Point2f(static_cast<float>(x_right), points_[i].y);
    candidates.push_back(points_[i]);
    index.push_back(i);
  }
  if (candidates.empty()) return;
  // 2. KLT refinement (single level: the guess is already within a pixel or two).
  std::vector<cv::Point2f> refined, back;
  for (size_t i : index) refined.push_back(guess[i]);
  std::vector<unsigned char> status, status_back;
  std::vector<float> err;
  const cv::Size window(config_.klt_window_px, config_.klt_window_px);
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                              config_.stereo_klt_iterations, 0.01);
  cv::calcOpticalFlowPyrLK(left_pyramid_, right_pyramid_, candidates, refined, status, err, window,
                           config_.stereo_klt_levels, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  back = candidates;
  cv::calcOpticalFlowPyrLK(right_pyramid_, left_pyramid_, refined, back, status_back, err, window,
                           config_.stereo_klt_levels, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  // 3. Row and consistency checks.
  for (size_t k = 0; k < index.size(); ++k) {
    const cv::Point2f& l = candidates[k];
    const cv::Point2f& r = refined[k];
    const bool ok = status[k] && status_back[k] && std::abs(r.y - l.y) <= config_.stereo_row_px &&
                    std::hypot(back[k].x - l.x, back[k].y - l.y) <= 1.0 && r.x <= l.x + 0.5 &&
                    r.x >= 0 && r.x < right.cols;
    if (!ok) continue;
    right_points_[index[k]] = r;
    has_right_[index[k]] = 1;
    disparity_[index[k]] = l.x - r.x;
    ++stats_.stereo;
  }
}

}  // namespace mapdelta::vio

// The front end's smoothing before detection and tracking (TrackerConfig::smooth_sigma_px):
// a dark, noisy stereo sequence of a textured plane sliding past the camera (the paper's dark
// scene with big noise: about 10 grey levels of noise on a dim image). Sized by the measured
// noise, the smoothing keeps more tracks alive; on a clean sequence it stays off.
// And the stereo search's uniqueness margin (TrackerConfig::stereo_min_margin): on a facade of
// repeated windows the best ZNCC along the row may be a wrong period; such matches are flagged.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "mapdelta/vio/feature_tracker.hpp"

namespace mapdelta::vio {
namespace {

constexpr int kWidth = 400, kHeight = 240, kDisparity = 12, kShiftPerFrame = 3, kFrames = 12;

// A dim texture (blobs at several scales, grey levels 10-70) wider than the frames.
cv::Mat DimTexture(unsigned seed) {
  cv::theRNG().state = seed;
  const int width = kWidth + kDisparity + kShiftPerFrame * kFrames;
  cv::Mat sum(kHeight, width, CV_32F, cv::Scalar(0));
  for (const double sigma : {1.5, 4.0}) {
    cv::Mat noise(kHeight, width, CV_32F), blurred;
    cv::randn(noise, 0.0, 1.0);
    cv::GaussianBlur(noise, blurred, cv::Size(), sigma);
    cv::normalize(blurred, blurred, -1.0, 1.0, cv::NORM_MINMAX);
    sum += blurred;
  }
  cv::Mat out;
  cv::normalize(sum, sum, 10.0, 70.0, cv::NORM_MINMAX);
  sum.convertTo(out, CV_8U);
  return out;
}

cv::Mat WithNoise(const cv::Mat& image, double sigma) {
  cv::Mat noise(image.size(), CV_32F), out;
  cv::randn(noise, 0.0, sigma);
  cv::Mat sum;
  image.convertTo(sum, CV_32F);
  sum += noise;
  sum.convertTo(out, CV_8U);  // saturating
  return out;
}

struct Tracks {
  size_t long_tracks = 0;  // features seen in at least 6 frames at the end
  double last_sigma = 0;   // smoothing applied to the last frame
};

Tracks RunTracker(double smooth_sigma_px, double noise_sigma) {
  const cv::Mat texture = DimTexture(7);
  TrackerConfig config;
  config.smooth_sigma_px = smooth_sigma_px;
  FeatureTracker tracker(config);
  cv::theRNG().state = 99;
  std::vector<TrackedFeature> features;
  for (int f = 0; f < kFrames; ++f) {
    const int x = kShiftPerFrame * f;
    // A plane at constant depth: the right image sees it kDisparity pixels to the left.
    const cv::Mat left =
        WithNoise(texture(cv::Rect(x + kDisparity, 0, kWidth, kHeight)), noise_sigma);
    const cv::Mat right = WithNoise(texture(cv::Rect(x, 0, kWidth, kHeight)), noise_sigma);
    features = tracker.Track(left, right);
  }
  Tracks out;
  for (const auto& feature : features) out.long_tracks += feature.track_count >= 6;
  out.last_sigma = tracker.last_stats().smooth_sigma_px;
  return out;
}

TEST(FeatureTracker, SmoothingSizedByTheNoiseKeepsTracksAliveInDarkNoisyImages) {
  const Tracks raw = RunTracker(0.0, 10.0);
  const Tracks smoothed = RunTracker(-1.0, 10.0);
  std::printf("dark, 10 grey levels of noise: long tracks raw %zu, smoothed (%.2f px) %zu\n",
              raw.long_tracks, smoothed.last_sigma, smoothed.long_tracks);
  EXPECT_EQ(raw.last_sigma, 0.0);
  // 10 grey levels: the cap, 2 px at 800 px, scaled to 1 px at this 400 px width.
  EXPECT_NEAR(smoothed.last_sigma, 1.0, 1e-9);
  EXPECT_GT(smoothed.long_tracks, raw.long_tracks + raw.long_tracks / 2);
}

TEST(FeatureTracker, NoSmoothingOnACleanSequence) {
  const Tracks clean = RunTracker(-1.0, 0.5);
  EXPECT_EQ(clean.last_sigma, 0.0);
  EXPECT_GT(clean.long_tracks, 50u);
}

// Left half: the dim blob texture; right half: a wall of identical windows every 20 px across
// and 24 px down. The whole view is a plane kDisparity px of disparity away.
cv::Mat TextureBesideWindows() {
  cv::Mat image;
  DimTexture(11)(cv::Rect(0, 0, kWidth + kDisparity, kHeight)).convertTo(image, CV_8U, 3.0, -20.0);
  const int facade_x = (kWidth + kDisparity) / 2;
  image(cv::Rect(facade_x, 0, image.cols - facade_x, kHeight)).setTo(cv::Scalar(150));
  for (int y = 4; y + 14 < kHeight; y += 24) {
    for (int x = facade_x + 4; x + 10 < image.cols; x += 20) {
      image(cv::Rect(x, y, 10, 14)).setTo(cv::Scalar(60));
    }
  }
  return image;
}

struct StereoCounts {
  // Stereo matches at the right disparity or not, and of those at a wrong one how many were
  // not flagged ambiguous; texture_ambiguous counts flagged matches on the unique texture.
  int texture_right = 0, texture_ambiguous = 0, facade_right = 0, facade_wrong = 0,
      facade_wrong_unflagged = 0;
};

StereoCounts MatchOnce(double min_margin) {
  const cv::Mat image = TextureBesideWindows();
  TrackerConfig config;
  config.stereo_min_margin = min_margin;
  FeatureTracker tracker(config);
  cv::theRNG().state = 5;
  // A point at column X of `image` is at X in the left view and X - kDisparity in the right.
  const cv::Mat left = WithNoise(image(cv::Rect(0, 0, kWidth, kHeight)), 2.0);
  const cv::Mat right = WithNoise(image(cv::Rect(kDisparity, 0, kWidth, kHeight)), 2.0);
  StereoCounts counts;
  const int facade_x = (kWidth + kDisparity) / 2;  // in the left image
  for (const TrackedFeature& f : tracker.Track(left, right)) {
    if (!f.has_right) {
      EXPECT_FALSE(f.stereo_ambiguous);
      continue;
    }
    const bool right_depth = std::abs(f.left_px.x() - f.right_px.x() - kDisparity) < 1.0;
    if (f.left_px.x() < facade_x - 8) {
      counts.texture_right += right_depth;
      counts.texture_ambiguous += f.stereo_ambiguous;
    } else if (f.left_px.x() > facade_x + 8) {
      counts.facade_right += right_depth;
      counts.facade_wrong += !right_depth;
      counts.facade_wrong_unflagged += !right_depth && !f.stereo_ambiguous;
    }
  }
  return counts;
}

TEST(FeatureTracker, TheStereoMarginFlagsAWrongPeriodOnRepeatedWindowsAsAmbiguous) {
  const StereoCounts off = MatchOnce(0.0);
  const StereoCounts margin = MatchOnce(0.05);
  std::printf(
      "texture right %d (ambiguous %d), facade right %d, wrong %d (unflagged %d); "
      "margin 0: %d (%d), %d, %d (%d)\n",
      margin.texture_right, margin.texture_ambiguous, margin.facade_right, margin.facade_wrong,
      margin.facade_wrong_unflagged, off.texture_right, off.texture_ambiguous, off.facade_right,
      off.facade_wrong, off.facade_wrong_unflagged);
  // The best ZNCC alone matches many windows one or more periods off; the flag is on only
  // with a margin, and then on every one of them, and on no more than a few texture matches.
  EXPECT_GT(margin.facade_wrong, 10);
  EXPECT_EQ(margin.facade_wrong_unflagged, 0);
  EXPECT_EQ(off.facade_wrong_unflagged, off.facade_wrong);
  EXPECT_GT(margin.texture_right, 50);
  EXPECT_LT(margin.texture_ambiguous, margin.texture_right / 10);
}

}  // namespace
}  // namespace mapdelta::vio

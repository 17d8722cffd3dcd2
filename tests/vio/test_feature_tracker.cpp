// The front end's smoothing before detection and tracking (TrackerConfig::smooth_sigma_px):
// a dark, noisy stereo sequence of a textured plane sliding past the camera (the paper's dark
// scene with big noise: about 10 grey levels of noise on a dim image). Sized by the measured
// noise, the smoothing keeps more tracks alive; on a clean sequence it stays off.
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

}  // namespace
}  // namespace mapdelta::vio

// RowZncc against OpenCV's matchTemplate(TM_CCOEFF_NORMED) on the same strips: random texture,
// a shifted copy (the peak must sit at the true disparity) and flat regions.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <random>

#include "mapdelta/vio/row_zncc.hpp"

namespace mapdelta::vio {
namespace {

cv::Mat RandomTexture(int width, int height, unsigned seed) {
  cv::theRNG().state = seed;
  cv::Mat noise(height, width, CV_8UC1);
  cv::randu(noise, 0, 256);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(5, 5), 1.2);
  return smooth;
}

TEST(RowZncc, EqualsMatchTemplateAndFindsTheShift) {
  constexpr int kHalf = 5, kShift = 37;
  const cv::Mat left = RandomTexture(320, 64, 3);
  cv::Mat right(left.size(), CV_8UC1, cv::Scalar(0));
  left(cv::Rect(kShift, 0, left.cols - kShift, left.rows))
      .copyTo(right(cv::Rect(0, 0, left.cols - kShift, left.rows)));
  // A flat band in the right image: its windows must score 0, as OpenCV's do.
  right(cv::Rect(0, 40, 120, 20)).setTo(cv::Scalar(90));
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> u_of(120, 300), v_of(kHalf, left.rows - kHalf - 1);
  std::vector<float> ours;
  for (int trial = 0; trial < 200; ++trial) {
    const int u = u_of(rng), v = v_of(rng);
    const int x0 = std::max(0, u - 100 - kHalf), x1 = u + kHalf + 1;
    cv::Mat reference;
    cv::matchTemplate(right(cv::Rect(x0, v - kHalf, x1 - x0, 2 * kHalf + 1)),
                      left(cv::Rect(u - kHalf, v - kHalf, 2 * kHalf + 1, 2 * kHalf + 1)), reference,
                      cv::TM_CCOEFF_NORMED);
    RowZncc(left, right, u, v, kHalf, x0 + kHalf, x1 - 1 - kHalf, &ours);
    ASSERT_EQ(ours.size(), static_cast<size_t>(reference.cols));
    for (int k = 0; k < reference.cols; ++k) {
      ASSERT_NEAR(ours[static_cast<size_t>(k)], reference.at<float>(0, k), 2e-4)
          << "u " << u << " v " << v << " k " << k;
    }
    if (v + kHalf < 40) {  // away from the flat band: the best match is the true shift
      const auto best = std::max_element(ours.begin(), ours.end()) - ours.begin();
      EXPECT_EQ(x0 + kHalf + best, u - kShift);
      EXPECT_GT(ours[static_cast<size_t>(best)], 0.999f);
    }
  }
}

TEST(RowZncc, FlatTemplateScoresZero) {
  const cv::Mat flat(32, 64, CV_8UC1, cv::Scalar(128));
  const cv::Mat textured = RandomTexture(64, 32, 5);
  std::vector<float> scores;
  RowZncc(flat, textured, 30, 15, 5, 10, 40, &scores);
  ASSERT_EQ(scores.size(), 31u);
  for (float s : scores) EXPECT_EQ(s, 0.f);
}

}  // namespace
}  // namespace mapdelta::vio

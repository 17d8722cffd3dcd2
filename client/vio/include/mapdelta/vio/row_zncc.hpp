#pragma once
// Zero-mean normalized cross-correlation of one left-image patch along a row of the right image:
// the coarse stereo search of the front end (feature_tracker.cpp).
#include <opencv2/core/mat.hpp>

#include <vector>

namespace mapdelta::vio {

// Scores of the (2 half + 1)^2 patch of `left` centred at (u, v) against the patches of `right`
// centred at (x, v), x = x_lo..x_hi: scores[x - x_lo] in [-1, 1], 0 where either patch is flat.
// The same numbers as cv::matchTemplate(TM_CCOEFF_NORMED) on that strip, computed directly:
// OpenCV correlates through a DFT whose set-up per call cost ~15 % of the VIO's CPU (perf on
// tiny S1_01) for strips of only 25-256 positions. Both images CV_8UC1; the caller keeps both
// patches inside the images.
void RowZncc(const cv::Mat& left, const cv::Mat& right, int u, int v, int half, int x_lo, int x_hi,
             std::vector<float>* scores);

}  // namespace mapdelta::vio

#pragma once
// Minimum filters over a square window, evaluated only where the caller needs them.
#include <vector>

#include "mapdelta/common/depth_image.hpp"

namespace mapdelta {

// Sliding-window minimum of n values read from `in` every `in_step` floats, over
// [i - w, i + w] clipped to the array, for every i (van Herk / Gil-Werman: a running minimum
// from each end of every block of 2w+1 values, so a window is the min of one suffix and one
// prefix; three comparisons per value whatever w is). `out` holds n values.
void SlidingWindowMin(const float* in, int in_step, int n, int w, float* out);

// For each pixel (u, v) with u and v multiples of `stride`: the smallest valid depth
// (finite, > 0) within +-window_px pixels in u and v, the window clipped to the image;
// +infinity when the window holds none. This is an erosion with a (2W+1)^2 rectangle and a
// replicated border, sampled on the stride grid. Rows are filtered over all columns, then only
// the strided columns down all rows. Result for (u, v) at
// [(v / stride) * cols + u / stride], cols = ceil(width / stride); rows = ceil(height / stride).
std::vector<float> NearestDepthAround(const DepthImage& depth, int window_px, int stride);

}  // namespace mapdelta

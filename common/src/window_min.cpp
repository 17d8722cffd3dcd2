#include "mapdelta/common/window_min.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include "mapdelta/common/error.hpp"

namespace mapdelta {

void SlidingWindowMin(const float* in, int in_step, int n, int w, float* out) {
  const float inf = std::numeric_limits<float>::infinity();
  const int k = 2 * w + 1;
  // Padded to whole blocks with +inf on both ends: the same as clipping the window, for a min.
  const int padded = ((n + 2 * w + k - 1) / k) * k;
  thread_local std::vector<float> value, pre, suf;
  value.assign(static_cast<size_t>(padded), inf);
  pre.resize(static_cast<size_t>(padded));
  suf.resize(static_cast<size_t>(padded));
  for (int i = 0; i < n; ++i)
    value[static_cast<size_t>(w + i)] = in[static_cast<ptrdiff_t>(i) * in_step];
  for (int block = 0; block < padded; block += k) {
    pre[block] = value[block];
    for (int j = block + 1; j < block + k; ++j) pre[j] = std::min(pre[j - 1], value[j]);
    suf[block + k - 1] = value[block + k - 1];
    for (int j = block + k - 2; j >= block; --j) suf[j] = std::min(suf[j + 1], value[j]);
  }
  // Output i's window is [i, i + 2w] in padded indices: a suffix of one block, a prefix of the
  // next (or one whole block).
  for (int i = 0; i < n; ++i) out[i] = std::min(suf[i], pre[i + 2 * w]);
}

std::vector<float> NearestDepthAround(const DepthImage& depth, int window_px, int stride) {
  if (window_px < 0 || stride < 1) {
    throw Error(ErrorCode::kInvalidArgument,
                "NearestDepthAround: need window_px >= 0 and stride >= 1");
  }
  const float inf = std::numeric_limits<float>::infinity();
  const int width = depth.width, height = depth.height;
  const int cols = (width + stride - 1) / stride, rows = (height + stride - 1) / stride;
  std::vector<float> row_in(static_cast<size_t>(width)), row_min(static_cast<size_t>(width));
  std::vector<float> horizontal(static_cast<size_t>(height) * cols);  // row minima at strided u
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const float d = depth.at(u, v);
      row_in[u] = (std::isfinite(d) && d > 0.f) ? d : inf;  // invalid pixels never win
    }
    SlidingWindowMin(row_in.data(), 1, width, window_px, row_min.data());
    for (int c = 0; c < cols; ++c) {
      horizontal[static_cast<size_t>(v) * cols + c] = row_min[static_cast<size_t>(c) * stride];
    }
  }
  std::vector<float> column_min(static_cast<size_t>(height));
  std::vector<float> result(static_cast<size_t>(rows) * cols);
  for (int c = 0; c < cols; ++c) {
    SlidingWindowMin(horizontal.data() + c, cols, height, window_px, column_min.data());
    for (int r = 0; r < rows; ++r) {
      result[static_cast<size_t>(r) * cols + c] = column_min[static_cast<size_t>(r) * stride];
    }
  }
  return result;
}

}  // namespace mapdelta

#include "mapdelta/vio/row_zncc.hpp"

#include <cmath>
#include <cstdint>

namespace mapdelta::vio {

void RowZncc(const cv::Mat& left, const cv::Mat& right, int u, int v, int half, int x_lo, int x_hi,
             std::vector<float>* scores) {
  const int side = 2 * half + 1, n = side * side;
  // Template minus its mean: then sum(T' * I) = sum(T' * (I - mean I)) for any window I.
  thread_local std::vector<float> templ;
  templ.resize(static_cast<size_t>(n));
  double t_sum = 0;
  for (int dy = -half; dy <= half; ++dy) {
    const uint8_t* row = left.ptr<uint8_t>(v + dy);
    for (int dx = -half; dx <= half; ++dx) t_sum += row[u + dx];
  }
  const float t_mean = static_cast<float>(t_sum / n);
  double t_norm2 = 0;
  for (int dy = -half, k = 0; dy <= half; ++dy) {
    const uint8_t* row = left.ptr<uint8_t>(v + dy);
    for (int dx = -half; dx <= half; ++dx, ++k) {
      templ[static_cast<size_t>(k)] = static_cast<float>(row[u + dx]) - t_mean;
      t_norm2 += static_cast<double>(templ[static_cast<size_t>(k)]) * templ[static_cast<size_t>(k)];
    }
  }
  const int count = x_hi - x_lo + 1;
  scores->assign(static_cast<size_t>(count), 0.f);
  if (!(t_norm2 > 1e-6)) return;  // flat template: no match is meaningful
  // All candidate windows at once, one template pixel at a time: each pass runs along a
  // contiguous stretch of the right row, which the compiler vectorizes (SSE/AVX). The
  // window-by-window loop it replaces ran 11-long inner loops that did not vectorize, and
  // this search is the front end's largest cost on real textures (client/vio/README.md).
  thread_local std::vector<float> cross_buf;
  thread_local std::vector<int32_t> sum_buf, sum2_buf;
  cross_buf.assign(static_cast<size_t>(count), 0.f);
  sum_buf.assign(static_cast<size_t>(count), 0);
  sum2_buf.assign(static_cast<size_t>(count), 0);
  float* __restrict cross = cross_buf.data();
  int32_t* __restrict sum = sum_buf.data();
  int32_t* __restrict sum2 = sum2_buf.data();
  for (int dy = -half, k = 0; dy <= half; ++dy) {
    const uint8_t* row = right.ptr<uint8_t>(v + dy) + (x_lo - half);
    for (int dx = 0; dx < side; ++dx, ++k) {
      const float t = templ[static_cast<size_t>(k)];
      const uint8_t* __restrict p = row + dx;
      for (int i = 0; i < count; ++i) {
        const int32_t q = p[i];
        cross[i] += t * static_cast<float>(q);
        sum[i] += q;
        sum2[i] += q * q;  // < 2^31 for windows up to 181x181
      }
    }
  }
  for (int i = 0; i < count; ++i) {
    const double s = sum[i];
    const double i_var = static_cast<double>(sum2[i]) - s * s / n;
    if (!(i_var > 1e-6)) continue;  // flat window
    (*scores)[static_cast<size_t>(i)] = static_cast<float>(cross[i] / std::sqrt(t_norm2 * i_var));
  }
}

}  // namespace mapdelta::vio

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
  scores->assign(static_cast<size_t>(x_hi - x_lo + 1), 0.f);
  if (!(t_norm2 > 1e-6)) return;  // flat template: no match is meaningful
  for (int x = x_lo; x <= x_hi; ++x) {
    int64_t sum = 0, sum2 = 0;
    float cross = 0;
    for (int dy = -half, k = 0; dy <= half; ++dy) {
      const uint8_t* row = right.ptr<uint8_t>(v + dy) + (x - half);
      for (int dx = 0; dx < side; ++dx, ++k) {
        const int p = row[dx];
        sum += p;
        sum2 += p * p;
        cross += templ[static_cast<size_t>(k)] * static_cast<float>(p);
      }
    }
    const double i_var =
        static_cast<double>(sum2) - static_cast<double>(sum) * static_cast<double>(sum) / n;
    if (!(i_var > 1e-6)) continue;  // flat window
    (*scores)[static_cast<size_t>(x - x_lo)] =
        static_cast<float>(cross / std::sqrt(t_norm2 * i_var));
  }
}

}  // namespace mapdelta::vio

#include "mapdelta/client/stereo_depth.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <vector>

#include "mapdelta/common/error.hpp"

namespace mapdelta::client {
namespace {

cv::Mat AsMat(const GrayImage& image) {
  return cv::Mat(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.pixels.data()));
}

}  // namespace

double EstimateImageNoise(const GrayImage& image) {
  return mapdelta::EstimateImageNoise(image.width, image.height, static_cast<size_t>(image.width),
                                      image.pixels.data());
}

struct StereoDepth::Impl {
  StereoConfig config;
};

StereoDepth::StereoDepth(const StereoConfig& config) : impl_(std::make_unique<Impl>()) {
  if (config.block_size < 1 || config.block_size % 2 == 0) {
    throw Error(ErrorCode::kInvalidArgument, "stereo.block_size must be odd and positive");
  }
  if (config.num_disparities < 16 || config.reference_width <= 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "stereo.num_disparities must be >= 16 and reference_width > 0");
  }
  impl_->config = config;
}
StereoDepth::~StereoDepth() = default;
StereoDepth::StereoDepth(StereoDepth&&) noexcept = default;
StereoDepth& StereoDepth::operator=(StereoDepth&&) noexcept = default;

int StereoDepth::NumDisparitiesFor(int width) const {
  const auto& c = impl_->config;
  const double scaled = static_cast<double>(c.num_disparities) * width / c.reference_width;
  return std::max(16, static_cast<int>(std::ceil(scaled / 16.0)) * 16);
}

int StereoDepth::UnmatchedBandFor(int width) const {
  if (width <= 1) return 0;
  return std::clamp(impl_->config.min_disparity + NumDisparitiesFor(width), 0, width - 1);
}

namespace {
void CheckBand(int band, int width) {
  if (band < 0 || band >= width) {
    throw Error(ErrorCode::kInvalidArgument, "stereo: crop band " + std::to_string(band) +
                                                 " px is outside [0, width " +
                                                 std::to_string(width) + ")");
  }
}
}  // namespace

PinholeCamera CropLeftBand(const PinholeCamera& camera, int band) {
  CheckBand(band, camera.width);
  PinholeCamera out = camera;
  out.width -= band;
  out.cx -= band;
  return out;
}

DepthImage CropLeftBand(const DepthImage& depth, int band) {
  CheckBand(band, depth.width);
  DepthImage out(depth.width - band, depth.height);
  for (int v = 0; v < depth.height; ++v) {
    const auto row = depth.depth_m.begin() + static_cast<ptrdiff_t>(v) * depth.width;
    std::copy(row + band, row + depth.width,
              out.depth_m.begin() + static_cast<ptrdiff_t>(v) * out.width);
  }
  return out;
}

DisparityImage StereoDepth::ComputeDisparity(const GrayImage& left, const GrayImage& right) const {
  if (left.width <= 0 || left.height <= 0 ||
      left.pixels.size() != static_cast<size_t>(left.width) * left.height) {
    throw Error(ErrorCode::kInvalidArgument, "stereo: left image is empty or inconsistent");
  }
  if (right.width != left.width || right.height != left.height ||
      right.pixels.size() != left.pixels.size()) {
    throw Error(ErrorCode::kInvalidArgument, "stereo: left and right images differ in size");
  }
  const auto& c = impl_->config;
  const int bs = c.block_size;
  const int num_disp = NumDisparitiesFor(left.width);
  // P1/P2 as OpenCV recommends for one channel: smoothness penalties grow with the block area.
  auto sgbm = cv::StereoSGBM::create(
      c.min_disparity, num_disp, bs, 8 * bs * bs, 32 * bs * bs, c.disp12_max_diff, c.pre_filter_cap,
      c.uniqueness_ratio, c.speckle_window_size, c.speckle_range, cv::StereoSGBM::MODE_SGBM_3WAY);
  cv::Mat fixed;  // CV_16S, disparity * 16 (4 fractional bits: the subpixel estimate)
  // At reference_width, scaled with the image like the disparity range: what smoothing costs
  // at depth edges grows with its size against the structures, which scale with the image.
  const double sigma =
      (c.denoise_sigma_px < 0 ? DenoiseSigmaFor(EstimateImageNoise(left)) : c.denoise_sigma_px) *
      left.width / c.reference_width;
  if (sigma > 0) {
    cv::Mat left_smooth, right_smooth;
    cv::GaussianBlur(AsMat(left), left_smooth, cv::Size(), sigma);
    cv::GaussianBlur(AsMat(right), right_smooth, cv::Size(), sigma);
    sgbm->compute(left_smooth, right_smooth, fixed);
  } else {
    sgbm->compute(AsMat(left), AsMat(right), fixed);
  }

  DisparityImage out{left.width, left.height, {}};
  out.disparity_px.assign(static_cast<size_t>(left.width) * left.height,
                          std::numeric_limits<float>::quiet_NaN());
  const int invalid_below = c.min_disparity * 16;  // SGBM marks failures with (min_disp-1)*16
  for (int v = 0; v < fixed.rows; ++v) {
    const auto* row = fixed.ptr<int16_t>(v);
    for (int u = 0; u < fixed.cols; ++u) {
      if (row[u] >= invalid_below && row[u] > 0) {
        out.disparity_px[static_cast<size_t>(v) * out.width + u] = row[u] / 16.f;
      }
    }
  }
  return out;
}

DepthImage StereoDepth::DepthFromDisparity(const DisparityImage& disparity, const StereoRig& rig,
                                           double max_depth_m) {
  DepthImage depth(disparity.width, disparity.height);
  for (size_t i = 0; i < disparity.disparity_px.size(); ++i) {
    const float d = disparity.disparity_px[i];
    if (!(d > 0.f)) continue;
    const double z = rig.DepthFromDisparity(d);
    if (z <= max_depth_m) depth.depth_m[i] = static_cast<float>(z);
  }
  return depth;
}

DepthImage StereoDepth::ComputeDepth(const GrayImage& left, const GrayImage& right,
                                     const StereoRig& rig) const {
  return DepthFromDisparity(ComputeDisparity(left, right), rig, impl_->config.max_depth_m);
}

}  // namespace mapdelta::client

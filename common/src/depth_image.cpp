#include "mapdelta/common/depth_image.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>

#include "mapdelta/common/error.hpp"

namespace mapdelta {
namespace {

cv::Mat ToMat16(const DepthImage& depth, double depth_scale) {
  if (depth.width <= 0 || depth.height <= 0 ||
      depth.depth_m.size() != static_cast<size_t>(depth.width) * depth.height) {
    throw Error(ErrorCode::kInvalidArgument, "depth image has inconsistent size");
  }
  cv::Mat mat(depth.height, depth.width, CV_16UC1);
  for (int v = 0; v < depth.height; ++v) {
    auto* row = mat.ptr<uint16_t>(v);
    for (int u = 0; u < depth.width; ++u) {
      const double d = depth.at(u, v);
      const double units = std::isfinite(d) && d > 0 ? std::round(d * depth_scale) : 0.0;
      row[u] = units > 65535.0 ? 0 : static_cast<uint16_t>(units);  // beyond range: no depth
    }
  }
  return mat;
}

DepthImage FromMat16(const cv::Mat& mat, double depth_scale, const std::string& what) {
  if (mat.empty()) throw Error(ErrorCode::kParse, what + ": not a decodable PNG image");
  if (mat.type() != CV_16UC1) {
    throw Error(ErrorCode::kParse, what + ": depth PNG must be 16-bit single channel");
  }
  DepthImage depth(mat.cols, mat.rows);
  for (int v = 0; v < mat.rows; ++v) {
    const auto* row = mat.ptr<uint16_t>(v);
    for (int u = 0; u < mat.cols; ++u) depth.at(u, v) = static_cast<float>(row[u] / depth_scale);
  }
  return depth;
}

}  // namespace

size_t DepthImage::CountValid() const {
  size_t n = 0;
  for (float d : depth_m) n += (std::isfinite(d) && d > 0.f) ? 1 : 0;
  return n;
}

DepthImage ReadDepthPng(const std::string& path, double depth_scale) {
  if (!std::filesystem::is_regular_file(path)) throw Error(ErrorCode::kIo, path + ": no such file");
  return FromMat16(cv::imread(path, cv::IMREAD_UNCHANGED), depth_scale, path);
}

void WriteDepthPng(const std::string& path, const DepthImage& depth, double depth_scale) {
  if (!cv::imwrite(path, ToMat16(depth, depth_scale))) {
    throw Error(ErrorCode::kIo, path + ": could not write depth PNG");
  }
}

std::vector<unsigned char> EncodeDepthPng(const DepthImage& depth, double depth_scale) {
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", ToMat16(depth, depth_scale), png)) {
    throw Error(ErrorCode::kInternal, "could not encode depth PNG");
  }
  return png;
}

DepthImage DecodeDepthPng(const std::vector<unsigned char>& png, double depth_scale) {
  static constexpr unsigned char kPngMagic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (png.size() < 8 || !std::equal(kPngMagic, kPngMagic + 8, png.begin())) {
    throw Error(ErrorCode::kParse, "depth image: not a PNG (bad signature)");
  }
  cv::Mat mat;
  try {
    mat = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    mat = cv::Mat();
  }
  return FromMat16(mat, depth_scale, "depth image");
}

}  // namespace mapdelta

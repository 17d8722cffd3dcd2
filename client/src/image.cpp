#include "mapdelta/client/image.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "mapdelta/common/error.hpp"

namespace mapdelta::client {

GrayImage ReadGrayImage(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw Error(ErrorCode::kIo, path + ": no such file");
  const cv::Mat mat = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (mat.empty()) throw Error(ErrorCode::kParse, path + ": not a decodable image");
  GrayImage image{mat.cols, mat.rows, {}};
  image.pixels.resize(static_cast<size_t>(mat.cols) * mat.rows);
  for (int v = 0; v < mat.rows; ++v) {
    std::memcpy(image.pixels.data() + static_cast<size_t>(v) * mat.cols, mat.ptr<uint8_t>(v),
                mat.cols);
  }
  return image;
}

void WriteDisparity(const std::string& path, const DisparityImage& d) {
  const auto ext = std::filesystem::path(path).extension().string();
  if (d.disparity_px.size() != static_cast<size_t>(d.width) * d.height) {
    throw Error(ErrorCode::kInvalidArgument, "disparity image has inconsistent size");
  }
  if (ext == ".pfm") {
    // PFM: "Pf", size, negative scale = little endian; rows stored bottom to top.
    std::ofstream out(path, std::ios::binary);
    out << "Pf\n" << d.width << " " << d.height << "\n-1.0\n";
    for (int v = d.height - 1; v >= 0; --v) {
      out.write(reinterpret_cast<const char*>(&d.disparity_px[static_cast<size_t>(v) * d.width]),
                static_cast<std::streamsize>(sizeof(float) * d.width));
    }
    if (!out) throw Error(ErrorCode::kIo, path + ": cannot write");
    return;
  }
  if (ext == ".tif" || ext == ".tiff") {
    cv::Mat mat(d.height, d.width, CV_32FC1);
    for (int v = 0; v < d.height; ++v) {
      for (int u = 0; u < d.width; ++u) {
        const float x = d.at(u, v);
        mat.at<float>(v, u) = std::isfinite(x) ? x : 0.f;
      }
    }
    if (!cv::imwrite(path, mat)) throw Error(ErrorCode::kIo, path + ": cannot write TIFF");
    return;
  }
  throw Error(ErrorCode::kUnsupported, path + ": disparity output must end in .pfm, .tif or .tiff");
}

DisparityImage ReadDisparityPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, path + ": cannot open");
  std::string magic;
  DisparityImage d;
  double scale = 0;
  in >> magic >> d.width >> d.height >> scale;
  in.get();
  if (!in || magic != "Pf" || d.width <= 0 || d.height <= 0 || scale >= 0 || d.width > 100000 ||
      d.height > 100000) {
    throw Error(ErrorCode::kParse, path + ": expected a little-endian single-channel PFM ('Pf')");
  }
  d.disparity_px.resize(static_cast<size_t>(d.width) * d.height);
  for (int v = d.height - 1; v >= 0; --v) {
    in.read(reinterpret_cast<char*>(&d.disparity_px[static_cast<size_t>(v) * d.width]),
            static_cast<std::streamsize>(sizeof(float) * d.width));
  }
  if (!in) throw Error(ErrorCode::kParse, path + ": truncated PFM data");
  return d;
}

}  // namespace mapdelta::client

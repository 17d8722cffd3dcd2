#pragma once
// Plain image types for the client's stages, so OpenCV stays inside .cpp files.
#include <cstdint>
#include <string>
#include <vector>

namespace mapdelta::client {

struct GrayImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> pixels;  // row-major
};

// Disparity in pixels, row-major; invalid = NaN. Convention x_right = x_left - d.
struct DisparityImage {
  int width = 0;
  int height = 0;
  std::vector<float> disparity_px;
  float at(int u, int v) const { return disparity_px[static_cast<size_t>(v) * width + u]; }
};

// Reads any 8-bit image (colour is converted to grey); throws Error(kIo) naming the file.
GrayImage ReadGrayImage(const std::string& path);
// Writes .pfm (float, NaN = invalid) or .tif/.tiff (32-bit float, invalid = 0).
void WriteDisparity(const std::string& path, const DisparityImage& disparity);
DisparityImage ReadDisparityPfm(const std::string& path);

}  // namespace mapdelta::client

#pragma once
// Depth images in metres, row-major, 0 = no depth. Stored as 16-bit PNG with depth_scale
// units per metre (default 1000: millimetres, so up to 65.5 m).
#include <string>
#include <vector>

namespace mapdelta {

struct DepthImage {
  int width = 0;
  int height = 0;
  std::vector<float> depth_m;  // width*height, 0 = invalid

  DepthImage() = default;
  DepthImage(int w, int h) : width(w), height(h), depth_m(static_cast<size_t>(w) * h, 0.f) {}
  float at(int u, int v) const { return depth_m[static_cast<size_t>(v) * width + u]; }
  float& at(int u, int v) { return depth_m[static_cast<size_t>(v) * width + u]; }
  size_t CountValid() const;
};

constexpr double kDefaultDepthScale = 1000.0;

DepthImage ReadDepthPng(const std::string& path, double depth_scale = kDefaultDepthScale);
void WriteDepthPng(const std::string& path, const DepthImage& depth,
                   double depth_scale = kDefaultDepthScale);
// In-memory PNG encoding (for uploads); decode throws Error(kParse) on bad data.
std::vector<unsigned char> EncodeDepthPng(const DepthImage& depth,
                                          double depth_scale = kDefaultDepthScale);
DepthImage DecodeDepthPng(const std::vector<unsigned char>& png,
                          double depth_scale = kDefaultDepthScale);

}  // namespace mapdelta

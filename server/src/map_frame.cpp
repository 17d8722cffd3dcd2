#include "mapdelta/server/map_frame.hpp"

#include <charconv>
#include <cmath>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/number_text.hpp"

namespace mapdelta::server {
bool SameFrame(const MapFrame& a, const MapFrame& b) {
  return a.crs == b.crs && (a.origin - b.origin).cwiseAbs().maxCoeff() <= 1e-6;
}

void RequireSameFrame(const MapFrame& stored, const MapFrame& frame) {
  if (!SameFrame(stored, frame)) {
    throw Error(ErrorCode::kConflict, "prior version in frame " + Describe(frame) +
                                          ", but the map's frame is " + Describe(stored));
  }
}

std::string DescribeOrigin(const Eigen::Vector3d& origin) {
  return "(" + ShortestNumber(origin.x()) + ", " + ShortestNumber(origin.y()) + ", " +
         ShortestNumber(origin.z()) + ")";
}

std::string Describe(const MapFrame& frame) {
  return (frame.crs.empty() ? std::string("no CRS") : frame.crs) + ", origin " +
         DescribeOrigin(frame.origin);
}

std::optional<Eigen::Vector3d> ParseOrigin(const std::string& text) {
  Eigen::Vector3d origin;
  std::stringstream ss(text);
  std::string item;
  int n = 0;
  while (std::getline(ss, item, ',')) {
    if (n == 3) return std::nullopt;
    const char* end = item.data() + item.size();
    const auto r = std::from_chars(item.data(), end, origin[n]);
    if (item.empty() || r.ec != std::errc() || r.ptr != end || !std::isfinite(origin[n]))
      return std::nullopt;
    ++n;
  }
  if (n != 3 || (!text.empty() && text.back() == ',')) return std::nullopt;
  return origin;
}

}  // namespace mapdelta::server

#include "query_params.hpp"

#include <cmath>
#include <sstream>

#include "api_json.hpp"
#include "mapdelta/server/api_error.hpp"

namespace mapdelta::server {

Rect TileRange(const TileGrid& grid, const MapFrame& frame, double min_x, double min_y,
               double max_x, double max_y) {
  const TileId a = grid.TileOf(min_x - frame.origin.x(), min_y - frame.origin.y());
  const TileId b = grid.TileOf(max_x - frame.origin.x(), max_y - frame.origin.y());
  return Rect{double(a.ix()), double(a.iy()), double(b.ix()), double(b.iy())};
}

TileId ParseTile(const std::string& text) {
  auto tile = TileId::FromString(text);
  if (!tile)
    throw ApiError(ApiCode::kInvalidArgument, "tile id '" + text + "' is not of the form ix_iy");
  return *tile;
}

nlohmann::json UserBounds(const TileGrid& grid, const MapFrame& frame, const TileId& tile) {
  const AxisAlignedBox b = grid.Bounds(tile);
  const Eigen::Vector3d lo = UserPoint(frame, b.min), hi = UserPoint(frame, b.max);
  return {lo.x(), lo.y(), hi.x(), hi.y()};
}

std::vector<double> ParseBbox(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const double d = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(d)) {
      throw ApiError(ApiCode::kInvalidArgument, "bbox: '" + item + "' is not a number");
    }
    v.push_back(d);
  }
  for (double d : v) {
    if (std::abs(d) > kMaxCoordinate)
      throw ApiError(ApiCode::kInvalidArgument, "bbox: coordinates must be within +-1e8 m");
  }
  if (v.size() != 4 || v[0] > v[2] || v[1] > v[3]) {
    throw ApiError(ApiCode::kInvalidArgument,
                   "bbox must be min_x,min_y,max_x,max_y with min <= max");
  }
  if (v[2] - v[0] > 1e6 || v[3] - v[1] > 1e6)
    throw ApiError(ApiCode::kInvalidArgument, "bbox larger than 1000 km");
  return v;
}

// The storage offset is (page - 1) * page_size: a page near 2^63 would overflow it.
constexpr int64_t kMaxPage = 1'000'000'000;

void CheckPage(int64_t page, int64_t page_size) {
  if (page < 1) throw ApiError(ApiCode::kInvalidArgument, "page must be >= 1");
  if (page_size < 1 || page_size > 1000)
    throw ApiError(ApiCode::kInvalidArgument, "page_size must be in [1, 1000]");
  // The storage offset is (page - 1) * page_size: a page near 2^63 would overflow it.
  if (page > kMaxPage)
    throw ApiError(ApiCode::kInvalidArgument, "page must be <= " + std::to_string(kMaxPage));
}

std::optional<std::set<ClusterState>> ParseClusterStates(const std::optional<std::string>& text,
                                                         bool single) {
  if (!text) return std::nullopt;
  std::set<ClusterState> states;
  std::stringstream ss(*text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const std::optional<ClusterState> state = ParseEnum<ClusterState>(item);
    if (!state) {
      throw ApiError(ApiCode::kInvalidArgument,
                     "query parameter 'state': '" + item +
                         "' is not one of candidate, confirmed, applied, expired, rejected");
    }
    states.insert(*state);
  }
  if (states.empty() || text->back() == ',')
    throw ApiError(ApiCode::kInvalidArgument, "query parameter 'state': expected a state name");
  if (single && text->find(',') != std::string::npos)
    throw ApiError(ApiCode::kInvalidArgument, "query parameter 'state': expected one state");
  return states;
}

}  // namespace mapdelta::server

#include "mapdelta/common/tiling.hpp"

#include <charconv>
#include <cmath>
#include <limits>

#include "mapdelta/common/error.hpp"

namespace mapdelta {

std::string TileId::ToString() const { return std::to_string(ix_) + "_" + std::to_string(iy_); }

std::optional<TileId> TileId::FromString(std::string_view text) {
  const size_t sep = text.find('_', 1);  // position 0 may hold a minus sign
  if (sep == std::string_view::npos) return std::nullopt;
  int32_t ix = 0, iy = 0;
  const auto parse = [](std::string_view s, int32_t* v) {
    if (s.empty()) return false;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), *v);
    return ec == std::errc() && end == s.data() + s.size();
  };
  if (!parse(text.substr(0, sep), &ix) || !parse(text.substr(sep + 1), &iy)) return std::nullopt;
  return TileId(ix, iy);
}

TileGrid::TileGrid(double tile_size_m) : tile_size_m_(tile_size_m) {
  if (!(tile_size_m > 0.0) || !std::isfinite(tile_size_m)) {
    throw Error(ErrorCode::kInvalidArgument, "tile_size_m must be a positive number");
  }
}

TileId TileGrid::TileOf(double x, double y) const {
  return TileId(static_cast<int32_t>(std::floor(x / tile_size_m_)),
                static_cast<int32_t>(std::floor(y / tile_size_m_)));
}

AxisAlignedBox TileGrid::Bounds(const TileId& tile) const {
  AxisAlignedBox box;
  const float lowest = std::numeric_limits<float>::lowest();
  const float highest = std::numeric_limits<float>::max();
  box.min = {static_cast<float>(tile.ix() * tile_size_m_),
             static_cast<float>(tile.iy() * tile_size_m_), lowest};
  box.max = {static_cast<float>((tile.ix() + 1) * tile_size_m_),
             static_cast<float>((tile.iy() + 1) * tile_size_m_), highest};
  return box;
}

std::vector<TileId> TileGrid::TilesInRect(double min_x, double min_y, double max_x,
                                          double max_y) const {
  std::vector<TileId> tiles;
  const TileId lo = TileOf(min_x, min_y), hi = TileOf(max_x, max_y);
  for (int32_t ix = lo.ix(); ix <= hi.ix(); ++ix) {
    for (int32_t iy = lo.iy(); iy <= hi.iy(); ++iy) tiles.emplace_back(ix, iy);
  }
  return tiles;
}

std::map<TileId, PointCloud> TileGrid::Split(const PointCloud& cloud) const {
  std::map<TileId, PointCloud> tiles;
  for (const auto& p : cloud) {
    if (!p.allFinite()) continue;
    tiles[TileOf(p)].push_back(p);
  }
  return tiles;
}

}  // namespace mapdelta

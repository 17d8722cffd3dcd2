#pragma once
// A square tile grid over the map frame's x/y plane. Tiles are the unit of storage,
// aggregation and partitioning. Tile (ix, iy) covers [ix*size, (ix+1)*size) x [iy*size, ...).
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

class TileId {
 public:
  TileId() = default;
  TileId(int32_t ix, int32_t iy) : ix_(ix), iy_(iy) {}
  int32_t ix() const { return ix_; }
  int32_t iy() const { return iy_; }
  // Text form "ix_iy", e.g. "3_-2"; stable, used in URLs, file names and SQL.
  std::string ToString() const;
  static std::optional<TileId> FromString(std::string_view text);
  auto operator<=>(const TileId&) const = default;

 private:
  int32_t ix_ = 0;
  int32_t iy_ = 0;
};

class TileGrid {
 public:
  explicit TileGrid(double tile_size_m = 50.0);  // throws if size is not positive and finite
  double tile_size_m() const { return tile_size_m_; }
  TileId TileOf(double x, double y) const;
  TileId TileOf(const Point& p) const { return TileOf(p.x(), p.y()); }
  // x/y bounds of the tile; z spans the whole float range.
  AxisAlignedBox Bounds(const TileId& tile) const;
  // Tiles whose area intersects the x/y rectangle [min, max].
  std::vector<TileId> TilesInRect(double min_x, double min_y, double max_x, double max_y) const;
  std::map<TileId, PointCloud> Split(const PointCloud& cloud) const;

 private:
  double tile_size_m_;
};

}  // namespace mapdelta

#pragma once
// Value types shared by the per-area stores.
#include <cstdint>
#include <vector>

namespace mapdelta::server {

// An opaque blob: the stores never look inside (the service layer encodes them, blob_codec).
using Bytes = std::vector<uint8_t>;

// A rectangle of tile indices, inclusive: tiles with min_x <= ix <= max_x and
// min_y <= iy <= max_y (the service converts metric boxes with TileGrid::TileOf).
struct Rect {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
};

}  // namespace mapdelta::server

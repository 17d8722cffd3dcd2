#pragma once
// Query parameters the facade's listings share (map_service_queries.cpp, map_service_clusters.cpp):
// a bbox in user coordinates, its tile range, and page checks. Errors are
// ApiError(kInvalidArgument) naming the parameter.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "mapdelta/common/tiling.hpp"
#include "mapdelta/server/map_frame.hpp"
#include "mapdelta/server/states.hpp"
#include "mapdelta/server/storage_types.hpp"

namespace mapdelta::server {

// "min_x,min_y,max_x,max_y" in user coordinates, min <= max, at most 1000 km a side.
std::vector<double> ParseBbox(const std::string& text);
// Tile index range of a rectangle in user coordinates, as a Rect of indices (what storage
// filters on); the grid is the map's local one.
Rect TileRange(const TileGrid& grid, const MapFrame& frame, double min_x, double min_y,
               double max_x, double max_y);
// "ix_iy" of a path; kInvalidArgument otherwise.
TileId ParseTile(const std::string& text);
// A tile's [min_x, min_y, max_x, max_y] in user coordinates.
nlohmann::json UserBounds(const TileGrid& grid, const MapFrame& frame, const TileId& tile);
// page >= 1 (and small enough for its offset not to overflow), page_size in [1, 1000].
void CheckPage(int64_t page, int64_t page_size);
// Query parameter 'state' of cluster routes: one state (single = true) or a comma-separated
// list of them; nullopt when the parameter is absent.
std::optional<std::set<ClusterState>> ParseClusterStates(const std::optional<std::string>& text,
                                                         bool single = false);

}  // namespace mapdelta::server

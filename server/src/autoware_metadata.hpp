#pragma once
// Autoware's grid point-cloud map metadata (`pointcloud_map_metadata.yaml`, read by Autoware's
// pointcloud_map_loader for differential map loading, written by autoware_pointcloud_divider):
//   x_resolution: 50
//   y_resolution: 50
//   pointcloud_map_0_-50.pcd: [0, -50]    # this file holds 0 <= x < 50, -50 <= y < 0
// One entry per tile file (a name relative to the metadata's folder) with the x/y of the
// tile's lower-left corner; the tile spans one resolution in x and one in y from there.
#include <string>
#include <vector>

namespace mapdelta::server {

struct AutowareTileEntry {
  std::string file;  // relative to the folder holding the metadata
  double x_min = 0, y_min = 0;
};

struct AutowareMetadata {
  double x_resolution = 0, y_resolution = 0;  // metres
  std::vector<AutowareTileEntry> tiles;       // in file order (export: by tile index)
};

// The metadata's file name inside an exported folder (what the map loader is pointed at).
inline constexpr const char* kAutowareMetadataFile = "pointcloud_map_metadata.yaml";

// The tile file name autoware_pointcloud_divider gives a tile with prefix "pointcloud_map":
// "pointcloud_map_<x_min>_<y_min>.pcd", coordinates in metres in their shortest exact form.
std::string AutowareTileFileName(double x_min, double y_min);

// Parses the metadata text; `what` (the file's path) prefixes every message. Throws
// Error(kParse) naming the key and what was expected: not YAML, not a mapping, a missing or
// non-positive resolution, an entry that is not [x_min, y_min] with finite numbers, a file
// name that leaves the folder (absolute or with ".."), no tile entry at all.
AutowareMetadata ParseAutowareMetadata(const std::string& text, const std::string& what);

// The metadata as YAML text in the order above (resolutions first, then the tiles).
std::string FormatAutowareMetadata(const AutowareMetadata& metadata);

}  // namespace mapdelta::server

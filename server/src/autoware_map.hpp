#pragma once
// The prior map as an Autoware grid map folder: tile PCDs plus pointcloud_map_metadata.yaml
// (autoware_metadata.hpp), what Autoware's pointcloud_map_loader loads.
//
// Coordinates: written and read as they are, in the server's map frame (local metres, z up),
// as float32. Autoware's map frame is usually a projected (MGRS/UTM) frame; georeferencing
// the map frame is issue #24, so until then the loader's map_projector_info must describe the
// same local frame (e.g. "local"), and nothing here offsets or rotates points.
#include <cstdint>
#include <string>

#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/server/prior_store.hpp"

namespace mapdelta::server {

// Reads every tile file the folder's metadata lists, each checked against its box
// [x_min, x_min + x_resolution) x [y_min, y_min + y_resolution) (within a float32 rounding
// step), and returns all their points. Throws Error naming the file: kIo for a folder without
// metadata or a missing tile file, kParse for malformed metadata, a tile listed twice or a
// point outside its tile's box (with the point and the box), and
// whatever ReadCloud throws for an unreadable PCD. Non-finite points are passed through (the
// importer drops and counts them).
PointCloud ReadAutowareMapFolder(const std::string& dir);

struct AutowareExportSummary {
  int64_t version = 0;
  double tile_size_m = 0;
  size_t tiles = 0;  // tile files written (tiles without points are not written)
  size_t points = 0;
  std::string metadata_path;
};

// Writes the prior map at `version` into `out_dir` (created if missing; refused with
// Error(kConflict) if it holds anything, so nothing of the user's is overwritten) as tiles of
// tile_size_m: binary PCD with x y z float32 per tile, named as autoware_pointcloud_divider
// names them, and the metadata file last (a folder without it is an interrupted export).
// Throws Error(kNotFound) for a version the store does not have, kIo when writing fails.
AutowareExportSummary ExportAutowareMap(PriorStore& priors, int64_t version, double tile_size_m,
                                        const std::string& out_dir);

}  // namespace mapdelta::server

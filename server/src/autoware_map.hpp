#pragma once
// The prior map as an Autoware grid map folder: tile PCDs plus pointcloud_map_metadata.yaml
// (autoware_metadata.hpp), what Autoware's pointcloud_map_loader loads.
//
// Coordinates: the tiles hold the map's local coordinates (float32, metres, z up), and
// map_projector_info.yaml (autoware_projector.hpp) says where they are: projector "Local" with
// the map's frame (CRS, origin) under mapdelta_frame. Nothing is rotated.
#include <cstdint>
#include <string>

#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/common/precise_cloud.hpp"
#include "mapdelta/server/map_frame.hpp"
#include "mapdelta/server/prior_store.hpp"

namespace mapdelta::server {

// Reads every tile file the folder's metadata lists, each checked against its box
// [x_min, x_min + x_resolution) x [y_min, y_min + y_resolution) (within a float32 rounding
// step), and returns all their points. Throws Error naming the file: kIo for a folder without
// metadata or a missing tile file, kParse for malformed metadata, a tile listed twice or a
// point outside its tile's box (with the point and the box), and
// whatever ReadCloud throws for an unreadable PCD. Non-finite points are passed through (the
// importer drops and counts them). Points come back in user coordinates (tile points + the
// origin of the folder's map_projector_info.yaml, if it has one); `request` gets that file's
// frame, and a part of it the caller already set must agree (else Error(kInvalidArgument)).
PrecisePointCloud ReadAutowareMapFolder(const std::string& dir, FrameRequest* request);

struct AutowareExportSummary {
  int64_t version = 0;
  double tile_size_m = 0;
  size_t tiles = 0;  // tile files written (tiles without points are not written)
  size_t points = 0;
  std::string metadata_path;
};

// Writes the prior map at `version` (its points local to `frame`, written so, with
// map_projector_info.yaml saying the frame) into `out_dir` (created if missing; refused with
// Error(kConflict) if it holds anything, so nothing of the user's is overwritten) as tiles of
// tile_size_m: binary PCD with x y z float32 per tile, named as autoware_pointcloud_divider
// names them, and the metadata file last (a folder without it is an interrupted export).
// Throws Error(kNotFound) for a version the store does not have, kIo when writing fails.
AutowareExportSummary ExportAutowareMap(PriorStore& priors, int64_t version, double tile_size_m,
                                        const std::string& out_dir, const MapFrame& frame);

}  // namespace mapdelta::server

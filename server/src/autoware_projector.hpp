#pragma once
// map_projector_info.yaml of an Autoware map folder: which coordinates its points are in.
// Autoware's own types (map_projection_loader): Local, MGRS, LocalCartesianUTM,
// TransverseMercator. We write and read "Local" (points as they are) with our frame beside it
// under a key of our own, `mapdelta_frame: {crs, origin: [x, y, z]}` (Autoware's loader reads
// only its keys): the tiles hold the map's local coordinates and user = local + origin. The
// geodetic types need a projection library (lat/lon to UTM) and are refused by name.
#include <string>

#include "mapdelta/server/map_frame.hpp"

namespace mapdelta::server {

inline constexpr const char* kAutowareProjectorFile = "map_projector_info.yaml";

// The frame the file states: an empty request for a plain Local projector. Throws
// Error(kParse) naming the file and key for malformed YAML, Error(kUnsupported) for another
// projector_type.
FrameRequest ParseAutowareProjector(const std::string& text, const std::string& path);
std::string FormatAutowareProjector(const MapFrame& frame);

}  // namespace mapdelta::server

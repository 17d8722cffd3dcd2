#pragma once
// PCD, PLY and LAS reading/writing (format chosen by extension). Errors name the file.
#include <string>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

// Reads .pcd, .ply or .las (1.0-1.4, uncompressed; las_io.hpp); throws Error(kIo / kParse /
// kUnsupported, also for .laz) naming the file.
PointCloud ReadCloud(const std::string& path);
// Writes .pcd (binary), .ply (binary little-endian) or .las (1.2, point format 0, mm
// resolution); throws Error(kIo).
void WriteCloud(const std::string& path, const PointCloud& cloud);

}  // namespace mapdelta

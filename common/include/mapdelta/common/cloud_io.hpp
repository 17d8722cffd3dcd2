#pragma once
// PCD and PLY reading/writing (format chosen by extension). Errors name the file.
#include <string>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

// Reads .pcd or .ply; throws Error(kIo / kParse / kUnsupported) naming the file.
PointCloud ReadCloud(const std::string& path);
// Writes .pcd (binary) or .ply (binary little-endian); throws Error(kIo).
void WriteCloud(const std::string& path, const PointCloud& cloud);

}  // namespace mapdelta

#pragma once
// PCD, PLY and LAS reading/writing (format chosen by extension). Errors name the file.
#include <cstdint>
#include <string>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

// Reads .pcd, .ply or .las (1.0-1.4, uncompressed; las_io.hpp); throws Error(kIo / kParse /
// kUnsupported, also for .laz) naming the file.
PointCloud ReadCloud(const std::string& path);
// Writes .pcd (binary), .ply (binary little-endian) or .las (1.2, point format 0, mm
// resolution); throws Error(kIo).
void WriteCloud(const std::string& path, const PointCloud& cloud);

// A changed point with its evidence (see docs/api.md): how many sessions observed the place
// and how many of them support the change, and the confidence derived from the two.
struct ChangeCloudPoint {
  Point position = Point::Zero();
  float confidence = 0;
  uint32_t observed_by = 0;
  uint32_t supported_by = 0;
};
// Writes .pcd (binary) or .ply (binary little-endian) with the fields x y z (float32),
// confidence (float32), observed_by, supported_by (uint32), so that PCL, CloudCompare and
// the like see the evidence beside each point; throws Error(kIo / kUnsupported).
void WriteChangeCloud(const std::string& path, const std::vector<ChangeCloudPoint>& points);

}  // namespace mapdelta

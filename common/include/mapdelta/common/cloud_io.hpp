#pragma once
// PCD, PLY and LAS reading/writing (format chosen by extension). Errors name the file.
#include <cstdint>
#include <string>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/common/precise_cloud.hpp"

namespace mapdelta {

// Reads .pcd, .ply or .las (1.0-1.4, uncompressed; las_io.hpp); throws Error(kIo / kParse /
// kUnsupported, also for .laz) naming the file. Points as stored, rounded to float32; a PCD's
// VIEWPOINT is not applied (a georeferenced tile from the server reads in the map's local
// frame, which is what on-board float math wants).
PointCloud ReadCloud(const std::string& path);
// The same in double, for georeferenced input (a UTM prior): float64 PCD/PLY fields and LAS
// integers are kept exactly, and a PCD's VIEWPOINT translation is added to every point (PCL's
// placement of a cloud, which the server's georeferenced PCDs carry); a VIEWPOINT with a
// rotation is refused (Error(kUnsupported)).
PrecisePointCloud ReadCloudPrecise(const std::string& path);

// Where written local points sit in the user's coordinates (user = local + origin) and the
// name of those coordinates' CRS (free text, e.g. EPSG:32632). The default writes the points
// as given, exactly as before maps had frames.
struct CloudFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::string crs;
  bool IsLocal() const { return origin.isZero(0) && crs.empty(); }
};
// Writes .pcd (binary), .ply (binary little-endian) or .las (1.2, point format 0, mm
// resolution); throws Error(kIo). With a frame that is not local: PCD keeps float32 local
// x y z (what PCL's point types load) and carries the exact origin as its VIEWPOINT
// translation (pcl_viewer places the cloud there) plus a "# crs" comment; PLY gets float64
// x y z in user coordinates (PDAL, CloudCompare and Open3D read double vertices exactly;
// PCL 1.13 does not cast them, so PCL users take the PCD); LAS is refused.
void WriteCloud(const std::string& path, const PointCloud& cloud, const CloudFrame& frame = {});

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
// the like see the evidence beside each point; throws Error(kIo / kUnsupported). A frame
// places the points as WriteCloud does (PLY: x y z float64 in user coordinates).
void WriteChangeCloud(const std::string& path, const std::vector<ChangeCloudPoint>& points,
                      const CloudFrame& frame = {});

}  // namespace mapdelta

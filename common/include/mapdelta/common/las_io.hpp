#pragma once
// ASPRS LAS 1.2 and 1.4 point clouds, uncompressed, for map teams' tools. Our own code:
// Debian 12 packages no PDAL, libLAS or LASzip (checked: apt-cache search pdal / liblas /
// laszip), and the part we need is small: the public header, then per point X, Y, Z as
// int32 with the header's scale and offset (the first 12 bytes of every point format 0-10).
// LAZ (LASzip-compressed LAS) stays out: its arithmetic-coded chunks need LASzip itself, which
// we cannot take from Debian, and a second implementation of it is not a small job.
// ReadCloud / WriteCloud (cloud_io.hpp) use these for ".las".
#include <string>
#include <string_view>

#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/common/precise_cloud.hpp"

namespace mapdelta {

struct LasWriteOptions {
  int minor_version = 2;   // 2: LAS 1.2, point format 0 (20 bytes); 4: LAS 1.4, format 6 (30 bytes)
  double scale_m = 0.001;  // coordinate resolution; offsets are the cloud's minimum, floored to 1 m
};

// The whole file in `bytes`; `path` names it in errors. Throws Error(kParse) naming the file
// and the header field for a malformed or truncated file, Error(kUnsupported) for LAZ or
// other versions. Points are returned in metres (X * scale + offset).
PointCloud ParseLas(std::string_view bytes, const std::string& path);
// The same in double: X * scale + offset without rounding to float32 (georeferenced files).
PrecisePointCloud ParseLasPrecise(std::string_view bytes, const std::string& path);
// The file's bytes. Throws Error(kInvalidArgument) when a coordinate does not fit the int32
// range at `scale_m` around the offset.
std::string EncodeLas(const PointCloud& cloud, const LasWriteOptions& options = {});

}  // namespace mapdelta

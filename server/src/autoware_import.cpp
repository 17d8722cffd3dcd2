// Reading an Autoware grid map folder (autoware_map.hpp) into one cloud for import-prior.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "autoware_map.hpp"
#include "autoware_metadata.hpp"
#include "autoware_projector.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"

namespace mapdelta::server {
namespace {

namespace fs = std::filesystem;

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, path.string() + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(ErrorCode::kIo, path.string() + ": cannot read");
  return text.str();
}

// Autoware's tools write float32 points, so a point computed on a box edge may land a rounding
// step beyond it: allow one millimetre or four float32 steps at that magnitude, if more.
double EdgeTolerance(double coordinate) {
  return std::max(1e-3, 4.0 * std::numeric_limits<float>::epsilon() * std::abs(coordinate));
}

bool InRange(double value, double min, double size) {
  const double tolerance = EdgeTolerance(min + size);
  return value >= min - tolerance && value < min + size + tolerance;
}

void CheckInsideBox(const PointCloud& cloud, const AutowareTileEntry& tile,
                    const AutowareMetadata& metadata, const fs::path& path) {
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Point& p = cloud[i];
    if (!p.allFinite()) continue;  // the importer drops and counts these
    if (InRange(p.x(), tile.x_min, metadata.x_resolution) &&
        InRange(p.y(), tile.y_min, metadata.y_resolution)) {
      continue;
    }
    std::ostringstream message;
    message << path.string() << ": point " << i << " (" << p.x() << ", " << p.y() << ", " << p.z()
            << ") lies outside the tile's box x in [" << tile.x_min << ", "
            << tile.x_min + metadata.x_resolution << "), y in [" << tile.y_min << ", "
            << tile.y_min + metadata.y_resolution << ") given by " << kAutowareMetadataFile;
    throw Error(ErrorCode::kParse, message.str());
  }
}

// The folder's projector, merged into what the caller asked for (they must agree).
void MergeProjector(const fs::path& dir, FrameRequest* request) {
  const fs::path path = dir / kAutowareProjectorFile;
  if (!fs::is_regular_file(path)) return;
  const FrameRequest stated = ParseAutowareProjector(ReadText(path), path.string());
  if (stated.crs && request->crs && *stated.crs != *request->crs) {
    throw Error(ErrorCode::kInvalidArgument, path.string() + ": crs '" + *stated.crs +
                                                 "' disagrees with the requested '" +
                                                 *request->crs + "'");
  }
  if (stated.origin && request->origin &&
      !SameFrame({"", *stated.origin}, {"", *request->origin})) {
    throw Error(ErrorCode::kInvalidArgument,
                path.string() + ": origin " + DescribeOrigin(*stated.origin) +
                    " disagrees with the requested " + DescribeOrigin(*request->origin));
  }
  if (stated.crs) request->crs = stated.crs;
  if (stated.origin) request->origin = stated.origin;
}

}  // namespace

PrecisePointCloud ReadAutowareMapFolder(const std::string& dir, FrameRequest* request) {
  MergeProjector(dir, request);
  // Without a projector origin the tiles are taken as user coordinates, as a plain file is.
  const Eigen::Vector3d offset = request->origin.value_or(Eigen::Vector3d::Zero());
  const fs::path metadata_path = fs::path(dir) / kAutowareMetadataFile;
  if (!fs::is_regular_file(metadata_path)) {
    throw Error(ErrorCode::kIo, dir + ": no " + std::string(kAutowareMetadataFile) +
                                    " (an Autoware grid map folder lists its tiles there)");
  }
  const AutowareMetadata metadata =
      ParseAutowareMetadata(ReadText(metadata_path), metadata_path.string());
  std::set<fs::path> seen;
  PrecisePointCloud all;
  for (const AutowareTileEntry& tile : metadata.tiles) {
    const fs::path path = (fs::path(dir) / tile.file).lexically_normal();
    if (!seen.insert(path).second) {
      throw Error(ErrorCode::kParse, metadata_path.string() + ": " + tile.file + " listed twice");
    }
    if (!fs::is_regular_file(path)) {
      throw Error(ErrorCode::kIo,
                  path.string() + ": listed in " + metadata_path.string() + " but missing");
    }
    const PointCloud cloud = ReadCloud(path.string());
    CheckInsideBox(cloud, tile, metadata, path);
    for (const Point& p : cloud) all.push_back(p.cast<double>() + offset);
  }
  return all;
}

}  // namespace mapdelta::server

// Writing a prior version as an Autoware grid map folder (autoware_map.hpp).
#include <filesystem>
#include <fstream>
#include <limits>

#include "autoware_map.hpp"
#include "autoware_metadata.hpp"
#include "autoware_projector.hpp"
#include "blob_codec.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/tiling.hpp"

namespace mapdelta::server {
namespace {

namespace fs = std::filesystem;

// Every stored tile's points at the version. The export's tile size may differ from the
// store's, so the points are gathered once and split again on the export grid.
PointCloud PriorPointsAt(PriorStore& priors, int64_t version) {
  constexpr double kLow = std::numeric_limits<int32_t>::min();
  constexpr double kHigh = std::numeric_limits<int32_t>::max();
  PointCloud all;
  for (const PriorTileRecord& listed : priors.ListTiles(Rect{kLow, kLow, kHigh, kHigh}, version)) {
    const auto tile = priors.GetTile(listed.tile, version);
    if (!tile) continue;  // listed a moment ago; a prior row is never deleted, so unreachable
    const PointCloud points = DecodePoints(tile->points);
    all.insert(all.end(), points.begin(), points.end());
  }
  return all;
}

void PrepareEmptyFolder(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error(ErrorCode::kIo, dir.string() + ": cannot create: " + ec.message());
  if (!fs::is_directory(dir)) throw Error(ErrorCode::kIo, dir.string() + ": not a directory");
  if (!fs::is_empty(dir)) {
    throw Error(ErrorCode::kConflict,
                dir.string() + ": not empty (the export writes into an empty or new folder)");
  }
}

// Written beside, then renamed: a reader never sees half a YAML file.
void WriteYaml(const fs::path& path, const std::string& text) {
  const fs::path partial = path.string() + ".partial";
  {
    std::ofstream out(partial, std::ios::binary);
    out << text;
    out.flush();
    if (!out) throw Error(ErrorCode::kIo, partial.string() + ": cannot write");
  }
  std::error_code ec;
  fs::rename(partial, path, ec);
  if (ec) throw Error(ErrorCode::kIo, path.string() + ": cannot write: " + ec.message());
}

}  // namespace

AutowareExportSummary ExportAutowareMap(PriorStore& priors, int64_t version, double tile_size_m,
                                        const std::string& out_dir, const MapFrame& frame) {
  const auto latest = priors.LatestVersion();
  if (!latest || version < 1 || version > *latest) {
    throw Error(ErrorCode::kNotFound,
                "prior version " + std::to_string(version) + " does not exist (latest: " +
                    (latest ? std::to_string(*latest) : std::string("none")) + ")");
  }
  const TileGrid grid(tile_size_m);
  const fs::path dir(out_dir);
  PrepareEmptyFolder(dir);

  AutowareExportSummary summary;
  summary.version = version;
  summary.tile_size_m = tile_size_m;
  AutowareMetadata metadata;
  metadata.x_resolution = metadata.y_resolution = tile_size_m;
  for (const auto& [tile, points] : grid.Split(PriorPointsAt(priors, version))) {
    // The corner as TileGrid computes it (index * size, in double, not Bounds' float box), so
    // names and metadata are exact for any tile size.
    const double x_min = tile.ix() * tile_size_m, y_min = tile.iy() * tile_size_m;
    const std::string file = AutowareTileFileName(x_min, y_min);
    WriteCloud((dir / file).string(), points);
    metadata.tiles.push_back({file, x_min, y_min});
    summary.points += points.size();
  }
  summary.tiles = metadata.tiles.size();
  WriteYaml(dir / kAutowareProjectorFile, FormatAutowareProjector(frame));
  summary.metadata_path = (dir / kAutowareMetadataFile).string();
  WriteYaml(summary.metadata_path, FormatAutowareMetadata(metadata));
  return summary;
}

}  // namespace mapdelta::server

// mapdelta-server export-autoware: a prior version as an Autoware grid map folder.
#include "cmd_export_autoware.hpp"

#include <cstdio>
#include <iostream>

#include "autoware_map.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/config.hpp"
#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

int ExportAutowareCommand(const std::vector<std::string>& args) {
  std::string config_path, out_dir;
  int64_t version = 0;
  double tile_size_m = 0;
  cli::Parser cli(
      "mapdelta-server export-autoware",
      "Writes prior version N as Autoware grid map tiles (binary PCD, x y z float32, named\n"
      "pointcloud_map_<x_min>_<y_min>.pcd) plus pointcloud_map_metadata.yaml, as Autoware's\n"
      "pointcloud_map_loader reads them. Coordinates stay in the server's map frame (local\n"
      "metres). The folder must be new or empty.");
  cli.Option("config", &config_path, "server configuration (YAML, see config/server.example.yaml)",
             "FILE")
      .Option("version", &version, "the prior version to export", "N")
      .Option("out", &out_dir, "the folder to write (created if missing)", "DIR")
      .Option("tile-size", &tile_size_m, "tile edge in metres (default: storage.tile_size_m)", "M")
      .Require({"config", "version", "out"})
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, std::cout)) return cli::kExitOk;
  if (version < 1) cli::FailUsage(cli.program(), "--version: expected >= 1");
  if (cli.Given("tile-size") && !(tile_size_m >= 0.1 && tile_size_m <= 100000)) {
    cli::FailUsage(cli.program(), "--tile-size: expected metres in [0.1, 100000]");
  }
  const ServerConfig config = LoadServerConfig(config_path);
  if (!cli.Given("tile-size")) tile_size_m = config.storage.tile_size_m;
  log::SetLevel(log::Level::kWarn);  // the summary below is the answer
  const auto storage = OpenSqliteStorage(config.storage.database);
  std::fprintf(stderr, "exporting prior version %lld to %s ...\n", static_cast<long long>(version),
               out_dir.c_str());
  const MapFrame frame = storage->priors().Frame().value_or(MapFrame{});
  const AutowareExportSummary s =
      ExportAutowareMap(storage->priors(), version, tile_size_m, out_dir, frame);
  std::printf(
      "prior_version: %lld\ntile_size_m: %g\ntiles: %zu\npoints: %zu\nmetadata: %s\nframe: %s\n",
      static_cast<long long>(s.version), s.tile_size_m, s.tiles, s.points, s.metadata_path.c_str(),
      Describe(frame).c_str());
  return cli::kExitOk;
}

}  // namespace mapdelta::server

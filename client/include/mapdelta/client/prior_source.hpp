#pragma once
// Where the prior map comes from: a local PCD/PLY file (offline mode) or the server's prior
// tiles around the vehicle (GET /v1/prior/tiles?x=&y=&radius=, then each tile as PCD), cached
// on disk per prior version and refreshed when the vehicle moves into other tiles.
//
// Frames: the client's float math (GICP, fusion, clouds) runs in a local frame, map
// coordinates minus MapOrigin(), so a georeferenced (UTM) prior keeps its millimetres. The
// server's origin comes from GET /v1/map and its PCD tiles are already local; a prior file's
// origin is chosen from the file (0 for a map near (0, 0)). Callers convert once at the
// edges: an initial pose in map coordinates minus the origin, uploaded poses plus it.
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mapdelta/client/http_transport.hpp"
#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/common/tiling.hpp"

namespace mapdelta::client {

class PriorSource {
 public:
  virtual ~PriorSource() = default;
  // Prior points within radius_m (x/y square) of (x, y), map frame. May throw Error(kIo).
  virtual PointCloud CloudAround(double x, double y, double radius_m) = 0;
  // Changes each time CloudAround would return a different set of points (new tiles).
  virtual std::string Key(double x, double y, double radius_m) = 0;
  // Where the local frame of CloudAround's points and (x, y) sits in map coordinates.
  virtual Eigen::Vector3d MapOrigin() = 0;
};

class FilePriorSource : public PriorSource {
 public:
  // Reads the cloud (voxel-downsampled to voxel_m if > 0). Throws Error naming the file.
  FilePriorSource(const std::string& path, double voxel_m, double tile_size_m = 50.0);
  PointCloud CloudAround(double x, double y, double radius_m) override;
  std::string Key(double x, double y, double radius_m) override;
  Eigen::Vector3d MapOrigin() override { return origin_; }
  size_t size() const { return cloud_.size(); }

 private:
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  PointCloud cloud_;  // local
  TileGrid grid_;
};

class ServerPriorSource : public PriorSource {
 public:
  ServerPriorSource(HttpTransport* transport, const std::string& cache_dir, double voxel_m);
  PointCloud CloudAround(double x, double y, double radius_m) override;
  std::string Key(double x, double y, double radius_m) override;
  // The map's origin from GET /v1/map (asked once). Throws Error(kIo / kParse).
  Eigen::Vector3d MapOrigin() override;
  size_t tiles_downloaded() const { return downloaded_; }

 private:
  struct Listing {
    int64_t version = 0;
    std::vector<std::pair<std::string, std::string>> tiles;  // tile id, url
  };
  Listing List(double x, double y, double radius_m);
  const PointCloud& Tile(int64_t version, const std::string& tile, const std::string& url);

  HttpTransport* transport_;
  std::string cache_dir_;
  double voxel_m_;
  std::map<std::string, PointCloud> memory_;  // "version/tile" -> points
  std::map<std::string, Listing> listings_;   // listing per query key
  size_t downloaded_ = 0;
  TileGrid grid_{50.0};
  std::optional<Eigen::Vector3d> origin_;
};

}  // namespace mapdelta::client

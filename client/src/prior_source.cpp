#include "mapdelta/client/prior_source.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/voxel_grid.hpp"

namespace mapdelta::client {
namespace fs = std::filesystem;
namespace {

// As the server's bound (server/include/mapdelta/server/map_frame.hpp): float32 keeps 0.25 mm
// within 8192 m of the origin.
constexpr double kLocalBoundM = 8192;

PointCloud CropXY(const PointCloud& cloud, double x, double y, double r) {
  AxisAlignedBox box;
  box.min = Eigen::Vector3f(static_cast<float>(x - r), static_cast<float>(y - r), -1e30f);
  box.max = Eigen::Vector3f(static_cast<float>(x + r), static_cast<float>(y + r), 1e30f);
  return Crop(cloud, box);
}

std::string KeyOf(const TileGrid& grid, double x, double y, double r) {
  std::ostringstream key;
  key << grid.TileOf(x, y).ToString() << "/r" << static_cast<int64_t>(std::ceil(r));
  return key.str();
}

}  // namespace

FilePriorSource::FilePriorSource(const std::string& path, double voxel_m, double tile_size_m)
    : grid_(tile_size_m) {
  // Read in double, then made local: float32 of a UTM file would round it to 0.5 m.
  PrecisePointCloud points = ReadCloudPrecise(path);
  RemoveNonFinite(&points);
  origin_ = ChooseLocalOrigin(points, kLocalBoundM, tile_size_m);
  cloud_.reserve(points.size());
  for (const auto& p : points) cloud_.push_back((p - origin_).cast<float>());
  if (voxel_m > 0) cloud_ = VoxelDownsample(cloud_, static_cast<float>(voxel_m));
  if (cloud_.empty())
    throw Error(ErrorCode::kInvalidArgument, path + ": prior cloud has no points");
  MD_LOG(kInfo, "prior: " << cloud_.size() << " points from " << path << ", local origin ("
                          << origin_.x() << ", " << origin_.y() << ", " << origin_.z() << ")");
}

PointCloud FilePriorSource::CloudAround(double x, double y, double r) {
  return CropXY(cloud_, x, y, r);
}

std::string FilePriorSource::Key(double x, double y, double r) { return KeyOf(grid_, x, y, r); }

ServerPriorSource::ServerPriorSource(HttpTransport* transport, const std::string& cache_dir,
                                     double voxel_m)
    : transport_(transport), cache_dir_(cache_dir), voxel_m_(voxel_m) {
  if (transport_ == nullptr)
    throw Error(ErrorCode::kInvalidArgument, "prior source needs a transport");
  std::error_code ec;
  fs::create_directories(cache_dir_, ec);
  if (ec) throw Error(ErrorCode::kIo, cache_dir_ + ": cannot create prior cache: " + ec.message());
}

std::string ServerPriorSource::Key(double x, double y, double r) { return KeyOf(grid_, x, y, r); }

Eigen::Vector3d ServerPriorSource::MapOrigin() {
  if (origin_) return *origin_;
  const HttpResponse res = transport_->Get("/v1/map");
  if (!res.Ok()) {
    throw Error(ErrorCode::kIo,
                "prior: GET /v1/map failed: " +
                    (res.status ? "HTTP " + std::to_string(res.status) : res.error));
  }
  try {
    const auto o = nlohmann::json::parse(res.body).at("origin");
    origin_ = Eigen::Vector3d(o.at(0).get<double>(), o.at(1).get<double>(), o.at(2).get<double>());
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kParse, "prior: GET /v1/map: " + std::string(e.what()));
  }
  return *origin_;
}

ServerPriorSource::Listing ServerPriorSource::List(double x, double y, double r) {
  const std::string key = Key(x, y, r);
  if (const auto it = listings_.find(key); it != listings_.end()) return it->second;
  // The listing asks in map coordinates; its tiles (ids, PCD points) are local.
  const Eigen::Vector3d origin = MapOrigin();
  std::ostringstream path;
  path.precision(17);
  path << "/v1/prior/tiles?x=" << x + origin.x() << "&y=" << y + origin.y() << "&radius=" << r;
  const HttpResponse res = transport_->Get(path.str());
  if (!res.Ok()) {
    throw Error(ErrorCode::kIo,
                "prior: GET " + path.str() +
                    " failed: " + (res.status ? "HTTP " + std::to_string(res.status) : res.error));
  }
  Listing listing;
  try {
    const auto j = nlohmann::json::parse(res.body);
    listing.version = j.at("prior_version").get<int64_t>();
    if (j.contains("tile_size_m")) grid_ = TileGrid(j.at("tile_size_m").get<double>());
    for (const auto& t : j.at("tiles")) {
      listing.tiles.emplace_back(t.at("tile").get<std::string>(), t.at("url").get<std::string>());
    }
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kParse, "prior: tile listing: " + std::string(e.what()));
  }
  listings_[Key(x, y, r)] = listing;
  return listing;
}

const PointCloud& ServerPriorSource::Tile(int64_t version, const std::string& tile,
                                          const std::string& url) {
  if (!TileId::FromString(tile))
    throw Error(ErrorCode::kParse, "prior: bad tile id '" + tile + "'");
  const std::string key = std::to_string(version) + "/" + tile;
  if (const auto it = memory_.find(key); it != memory_.end()) return it->second;
  const fs::path dir = fs::path(cache_dir_) / ("v" + std::to_string(version));
  const fs::path file = dir / (tile + ".pcd");
  if (!fs::exists(file)) {
    const HttpResponse res =
        transport_->Get(url + (url.find('?') == std::string::npos ? "?" : "&") + "format=pcd");
    if (!res.Ok()) {
      throw Error(ErrorCode::kIo,
                  "prior: GET " + url + " failed: " +
                      (res.status ? "HTTP " + std::to_string(res.status) : res.error));
    }
    fs::create_directories(dir);
    // Download to a temporary name first: a crash never leaves a truncated tile in the cache.
    const fs::path tmp = file.string() + ".tmp";
    {
      std::ofstream out(tmp, std::ios::binary);
      out.write(res.body.data(), static_cast<std::streamsize>(res.body.size()));
      if (!out) throw Error(ErrorCode::kIo, tmp.string() + ": cannot write prior cache");
    }
    fs::rename(tmp, file);
    ++downloaded_;
  }
  PointCloud cloud = ReadCloud(file.string());  // local: the VIEWPOINT (origin) is not applied
  RemoveNonFinite(&cloud);
  if (voxel_m_ > 0) cloud = VoxelDownsample(cloud, static_cast<float>(voxel_m_));
  return memory_[key] = std::move(cloud);
}

PointCloud ServerPriorSource::CloudAround(double x, double y, double r) {
  const Listing listing = List(x, y, r);
  PointCloud out;
  for (const auto& [tile, url] : listing.tiles) {
    const PointCloud& points = Tile(listing.version, tile, url);
    out.insert(out.end(), points.begin(), points.end());
  }
  return CropXY(out, x, y, r);
}

}  // namespace mapdelta::client

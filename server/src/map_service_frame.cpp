// MapService: the map's frame (map_frame.hpp), prior import (where user coordinates become
// local ones) and GET /v1/map.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "api_json.hpp"
#include "autoware_map.hpp"
#include "blob_codec.hpp"
#include "coverage.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/number_text.hpp"
#include "mapdelta/server/map_service.hpp"

namespace mapdelta::server {
namespace {

Json FrameJson(const MapFrame& frame) {
  return Json{{"crs", frame.crs},
              {"origin", {frame.origin.x(), frame.origin.y(), frame.origin.z()}}};
}

// Which part of a request disagrees with the map's frame, or "" if none does.
std::string Disagreement(const FrameRequest& request, const MapFrame& stored) {
  if (request.crs && *request.crs != stored.crs)
    return "CRS '" + *request.crs + "' differs from the map's '" + stored.crs + "'";
  if (request.origin && !SameFrame(MapFrame{stored.crs, *request.origin}, stored))
    return "origin " + DescribeOrigin(*request.origin) + " differs";
  return "";
}

// User points in the frame's local coordinates, float32; refuses the first point the bound
// would round by more than a quarter of a millimetre.
PointCloud ToLocal(const PrecisePointCloud& user, const MapFrame& frame) {
  PointCloud local;
  local.reserve(user.size());
  for (size_t i = 0; i < user.size(); ++i) {
    const Eigen::Vector3d l = user[i] - frame.origin;
    if (l.cwiseAbs().maxCoeff() > kMaxLocalCoordinateM) {
      throw ApiError(ApiCode::kInvalidArgument,
                     "prior cloud: point " + std::to_string(i) + " (" +
                         ShortestNumber(user[i].x()) + ", " + ShortestNumber(user[i].y()) + ", " +
                         ShortestNumber(user[i].z()) + ") lies more than " +
                         ShortestNumber(kMaxLocalCoordinateM) + " m from the map origin (" +
                         Describe(frame) +
                         "); float32 local coordinates would not keep it to 1 mm there. Give an "
                         "origin inside the cloud (--origin X,Y,Z) or split the map");
    }
    local.push_back(l.cast<float>());
  }
  return local;
}

}  // namespace

MapFrame MapService::Frame() {
  std::lock_guard lock(frame_mutex_);
  if (!frame_) frame_ = storage_->priors().Frame();  // another process may store it later
  return frame_.value_or(MapFrame{});
}

SE3 MapService::LocalPose(const SE3& T_map_cam_user) {
  const MapFrame frame = Frame();
  SE3 T = T_map_cam_user;
  T.translation() -= frame.origin;
  if (T.translation().cwiseAbs().maxCoeff() > kMaxLocalCoordinateM) {
    const Eigen::Vector3d& t = T_map_cam_user.translation();
    throw ApiError(ApiCode::kInvalidArgument,
                   "field 'T_map_cam': position (" + ShortestNumber(t.x()) + ", " +
                       ShortestNumber(t.y()) + ", " + ShortestNumber(t.z()) + ") is more than " +
                       ShortestNumber(kMaxLocalCoordinateM) + " m from the map origin (" +
                       Describe(frame) + "); poses are in the map's coordinates (GET /v1/map)");
  }
  return T;
}

MapFrame MapService::ResolveImportFrame(const FrameRequest& request,
                                        const PrecisePointCloud& user_points, bool* chosen) {
  *chosen = false;
  const std::optional<MapFrame> stored = storage_->priors().Frame();
  if (stored || storage_->priors().LatestVersion()) {
    // A map from before frames has its points at origin 0 without a CRS.
    const MapFrame current = stored.value_or(MapFrame{});
    const std::string why = Disagreement(request, current);
    if (!why.empty()) {
      throw ApiError(ApiCode::kInvalidArgument,
                     "prior import refused, nothing stored: the map's "
                     "frame is " +
                         Describe(current) + " and this import's " + why +
                         " (a map's frame is set by its first import)");
    }
    return current;
  }
  MapFrame frame;
  frame.crs = request.crs.value_or("");
  const bool printable = std::all_of(frame.crs.begin(), frame.crs.end(), [](char c) {
    return c >= 0x20 && c < 0x7f && c != '"' && c != '\\';
  });
  if (frame.crs.size() > 128 || !printable) {
    throw ApiError(ApiCode::kInvalidArgument,
                   "crs: expected a name such as EPSG:32632 (at most 128 printable ASCII "
                   "characters, no quotes or backslashes)");
  }
  *chosen = !request.origin;
  frame.origin = request.origin ? *request.origin
                                : ChooseLocalOrigin(user_points, kMaxLocalCoordinateM,
                                                    config_.storage.tile_size_m);
  return frame;
}

Json MapService::ImportPriorFile(const std::string& path, const std::string& note,
                                 const FrameRequest& frame_request) {
  PrecisePointCloud user;
  FrameRequest request = frame_request;
  try {
    // A folder is an Autoware grid map (tiles + pointcloud_map_metadata.yaml, and the
    // projector its coordinates are relative to, map_projector_info.yaml, if present).
    user = std::filesystem::is_directory(path) ? ReadAutowareMapFolder(path, &request)
                                               : ReadCloudPrecise(path);
  } catch (const Error& e) {
    throw ApiError(ApiCode::kInvalidArgument, std::string("prior cloud: ") + e.what());
  }
  const size_t dropped = RemoveNonFinite(&user);
  if (user.empty()) throw ApiError(ApiCode::kInvalidArgument, "prior cloud has no finite points");
  for (size_t i = 0; i < user.size(); ++i) {
    if (user[i].cwiseAbs().maxCoeff() > kMaxCoordinate) {
      throw ApiError(ApiCode::kInvalidArgument,
                     "prior cloud: point " + std::to_string(i) + " lies beyond +-1e8 m");
    }
  }
  bool chosen = false;
  const MapFrame frame = ResolveImportFrame(request, user, &chosen);
  const PointCloud cloud = ToLocal(user, frame);
  const TileGrid grid(config_.storage.tile_size_m);
  std::vector<PriorTileRecord> tiles;
  for (const auto& [tile, points] : grid.Split(cloud)) {
    PriorTileRecord r;
    r.tile = tile;
    r.point_count = static_cast<int64_t>(points.size());
    r.points = EncodePoints(points);
    tiles.push_back(std::move(r));
  }
  PriorVersionRecord meta;
  meta.created_ms = NowMs();
  meta.source = PriorSource::kImport;
  meta.note = note;
  meta.frame = frame;
  int64_t version = 0;
  try {
    version = storage_->priors().CreateVersion(meta, tiles, /*replace_all=*/true);
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kConflict) throw;
    // Another import stored a different frame since ResolveImportFrame read it.
    throw ApiError(ApiCode::kInvalidArgument,
                   std::string("prior import refused, nothing stored: ") + e.what());
  }
  MD_LOG(kInfo, "prior version " << version << " imported: " << cloud.size() << " points in "
                                 << tiles.size() << " tiles (" << dropped
                                 << " non-finite dropped), frame " << Describe(frame)
                                 << (chosen ? " (origin chosen from the cloud)" : ""));
  // Sessions' coverage of the replaced tiles, against the new points.
  const CoverageRecomputed coverage = RecomputeCoverage(*storage_);
  Json out{{"prior_version", version},
           {"points", cloud.size()},
           {"tiles", tiles.size()},
           {"dropped_non_finite", dropped},
           {"tile_size_m", config_.storage.tile_size_m},
           {"frame", FrameJson(frame)},
           {"origin_chosen", chosen}};
  out["coverage_rows_recomputed"] = coverage.rows;
  return out;
}

Json MapService::GetMap() {
  const MapFrame frame = Frame();
  Json out = FrameJson(frame);
  const std::optional<int64_t> version = storage_->priors().LatestVersion();
  out["prior_version"] = version ? Json(*version) : Json(nullptr);
  out["tile_size_m"] = config_.storage.tile_size_m;
  out["local_limit_m"] = kMaxLocalCoordinateM;
  out["extent"] = nullptr;
  if (!version) return out;
  // The extent of the non-empty tiles (cheap: no point is decoded), in user coordinates.
  const TileGrid grid(config_.storage.tile_size_m);
  constexpr double kAll = std::numeric_limits<int32_t>::max();
  const auto tiles = storage_->priors().ListTiles(Rect{-kAll, -kAll, kAll, kAll}, *version);
  if (tiles.empty()) return out;
  Eigen::Vector3f lo = grid.Bounds(tiles.front().tile).min,
                  hi = grid.Bounds(tiles.front().tile).max;
  for (const auto& t : tiles) {
    const AxisAlignedBox b = grid.Bounds(t.tile);
    lo = lo.cwiseMin(b.min);
    hi = hi.cwiseMax(b.max);
  }
  const Eigen::Vector3d a = UserPoint(frame, lo), b = UserPoint(frame, hi);
  out["extent"] = {a.x(), a.y(), b.x(), b.y()};
  out["tiles"] = tiles.size();
  return out;
}

}  // namespace mapdelta::server

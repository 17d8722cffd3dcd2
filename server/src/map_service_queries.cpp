// MapService: prior map import and queries, change queries, admin jobs.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "api_json.hpp"
#include "autoware_map.hpp"
#include "blob_codec.hpp"
#include "cluster_voxels.hpp"
#include "jobs.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/number_text.hpp"
#include "mapdelta/server/map_service.hpp"
#include "query_params.hpp"

namespace mapdelta::server {
namespace {

// A temporary file removed on scope exit (cloud and octree IO in common is file-based).
class TempFile {
 public:
  explicit TempFile(const std::string& ext) {
    static std::atomic<int> counter{0};
    path_ = (std::filesystem::temp_directory_path() /
             ("mapdelta-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ext))
                .string();
  }
  ~TempFile() {
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
  const std::string& path() const { return path_; }
  Bytes Read() const {
    std::ifstream in(path_, std::ios::binary);
    if (!in) throw Error(ErrorCode::kIo, path_ + ": cannot read back");
    return Bytes(std::istreambuf_iterator<char>(in), {});
  }
  void Write(const Bytes& bytes) const {
    std::ofstream out(path_, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
    if (!out) throw Error(ErrorCode::kIo, path_ + ": cannot write");
  }

 private:
  std::string path_;
};

// The bytes of a cloud file: `write(path, cloud)` is WriteCloud or WriteChangeCloud.
template <typename Cloud, typename Writer>
FilePayload CloudPayload(const Cloud& cloud, const std::string& format, const MapFrame& frame,
                         Writer write) {
  if (format != "pcd" && format != "ply") {
    throw ApiError(ApiCode::kInvalidArgument, "format must be pcd or ply");
  }
  TempFile f("." + format);
  write(f.path(), cloud, CloudFrame{frame.origin, frame.crs});
  FilePayload p;
  p.bytes = f.Read();
  p.content_type = format == "pcd" ? "application/x-pcd" : "application/x-ply";
  return p;
}

Json JobToJson(const JobRecord& j) {
  Json out{{"job_id", j.id},
           {"type", ToString(j.type)},
           {"state", ToString(j.state)},
           {"progress", j.progress},
           {"message", j.message},
           {"params", Json::parse(j.params_json)},
           {"attempts", j.attempts},
           {"cancel_requested", j.cancel_requested},
           {"created_at", IsoTime(j.created_ms)}};
  if (j.started_ms) out["started_at"] = IsoTime(*j.started_ms);
  if (j.finished_ms) out["finished_at"] = IsoTime(*j.finished_ms);
  if (j.result_json) out["result"] = Json::parse(*j.result_json);
  return out;
}

}  // namespace

int64_t MapService::RequirePriorVersion() {
  auto v = storage_->priors().LatestVersion();
  if (!v) throw ApiError(ApiCode::kNoPrior, "no prior map has been imported yet");
  return *v;
}

// ---------------------------------------------------------------- prior map

Json MapService::ImportPrior(const Bytes& bytes, const std::string& format, const std::string& note,
                             const FrameRequest& frame) {
  if (format != "pcd" && format != "ply")
    throw ApiError(ApiCode::kInvalidArgument, "format must be pcd or ply");
  if (bytes.empty()) throw ApiError(ApiCode::kInvalidArgument, "body is empty");
  TempFile f("." + format);
  f.Write(bytes);
  return ImportPriorFile(f.path(), note, frame);
}

Json MapService::ListPriorTilesNear(double x, double y, double radius_m,
                                    std::optional<int64_t> version) {
  if (!(std::abs(x) <= kMaxCoordinate && std::abs(y) <= kMaxCoordinate)) {
    throw ApiError(ApiCode::kInvalidArgument, "x and y must be finite and within +-1e8 m");
  }
  if (!(radius_m >= 0 && radius_m <= 10000))
    throw ApiError(ApiCode::kInvalidArgument, "radius must be in [0, 10000] m");
  const int64_t latest = RequirePriorVersion();
  const int64_t v = version.value_or(latest);
  if (v < 1 || v > latest)
    throw ApiError(ApiCode::kNotFound, "prior version " + std::to_string(v) + " does not exist");
  const TileGrid grid(config_.storage.tile_size_m);
  const MapFrame frame = Frame();
  Json tiles = Json::array();
  for (const PriorTileRecord& t : storage_->priors().ListTiles(
           TileRange(grid, frame, x - radius_m, y - radius_m, x + radius_m, y + radius_m), v)) {
    tiles.push_back(
        {{"tile", t.tile.ToString()},
         {"points", t.point_count},
         {"tile_version", t.version},
         {"bounds", UserBounds(grid, frame, t.tile)},
         {"url", "/v1/prior/tiles/" + t.tile.ToString() + "?version=" + std::to_string(v)}});
  }
  return Json{{"prior_version", v}, {"tile_size_m", grid.tile_size_m()}, {"tiles", tiles}};
}

FilePayload MapService::GetPriorTile(const std::string& tile_text, std::optional<int64_t> version,
                                     const std::string& format) {
  const TileId tile = ParseTile(tile_text);
  const int64_t latest = RequirePriorVersion();
  const int64_t v = version.value_or(latest);
  if (v < 1 || v > latest)
    throw ApiError(ApiCode::kNotFound, "prior version " + std::to_string(v) + " does not exist");
  auto record = storage_->priors().GetTile(tile, v);
  if (!record)
    throw ApiError(ApiCode::kNotFound,
                   "tile " + tile_text + " has no prior points at version " + std::to_string(v));
  FilePayload p = CloudPayload(DecodePoints(record->points), format, Frame(),
                               [](const std::string& path, const PointCloud& cloud,
                                  const CloudFrame& frame) { WriteCloud(path, cloud, frame); });
  p.prior_version = v;
  // The row's own version names the bytes (a tile unchanged since reads the same at v and v+1).
  p.etag =
      "\"prior-" + tile.ToString() + "-r" + std::to_string(record->version) + "-" + format + "\"";
  p.immutable = version.has_value();  // "the latest" moves on; version N never changes
  return p;
}

Json MapService::ListPriorVersions() {
  Json out = Json::array();
  for (const auto& v : storage_->priors().ListVersions()) {
    Json j{{"version", v.version},
           {"created_at", IsoTime(v.created_ms)},
           {"source", ToString(v.source)},
           {"note", v.note}};
    if (v.parent) j["parent"] = *v.parent;
    if (v.job_id) j["job_id"] = *v.job_id;
    out.push_back(j);
  }
  return Json{{"versions", out}};
}

// ---------------------------------------------------------------- changes

Json MapService::ListChangedTiles(const std::string& bbox, double min_confidence, int64_t page,
                                  int64_t page_size, int64_t min_support) {
  const std::vector<double> b = ParseBbox(bbox);
  CheckPage(page, page_size);
  if (!(min_confidence >= 0 && min_confidence <= 1))
    throw ApiError(ApiCode::kInvalidArgument, "min_confidence must be in [0, 1]");
  if (min_support < 0) throw ApiError(ApiCode::kInvalidArgument, "min_support must be >= 0");
  const TileGrid grid(config_.storage.tile_size_m);
  const MapFrame frame = Frame();
  const Rect range = TileRange(grid, frame, b[0], b[1], b[2], b[3]);
  int64_t total = 0;
  std::vector<TileChangesRecord> listed;
  if (min_support == 0) {
    listed = storage_->tiles().ListChanged(range, min_confidence, page_size, (page - 1) * page_size,
                                           &total);
  } else {
    // Per point: a tile is listed if one of its changes passes both thresholds, with the
    // counts of those that pass. Candidates are the tiles whose best confidence passes.
    constexpr int64_t kMaxCandidates = 10000;
    int64_t candidates = 0;
    const auto all =
        storage_->tiles().ListChanged(range, min_confidence, kMaxCandidates + 1, 0, &candidates);
    if (candidates > kMaxCandidates) {
      throw ApiError(ApiCode::kInvalidArgument, "min_support filtering covers at most " +
                                                    std::to_string(kMaxCandidates) +
                                                    " changed tiles; use a smaller bbox");
    }
    for (const TileChangesRecord& summary : all) {
      auto full = storage_->tiles().GetChanges(summary.tile);
      if (!full) continue;
      TileChangesRecord r = *full;
      r.new_count = r.removed_count = 0;
      r.max_confidence = 0;
      for (const ChangePoint& c : DecodeChanges(full->changes)) {
        if (c.confidence < min_confidence ||
            static_cast<int64_t>(c.supported_by.size()) < min_support)
          continue;
        (c.kind == ChangeKind::kNew ? r.new_count : r.removed_count) += 1;
        r.max_confidence = std::max(r.max_confidence, double{c.confidence});
      }
      if (r.new_count + r.removed_count == 0) continue;
      if (total >= (page - 1) * page_size && total < page * page_size)
        listed.push_back(std::move(r));
      ++total;
    }
  }
  Json tiles = Json::array();
  for (const auto& c : listed) {
    tiles.push_back({{"tile", c.tile.ToString()},
                     {"new_count", c.new_count},
                     {"removed_count", c.removed_count},
                     {"max_confidence", c.max_confidence},
                     {"prior_version", c.prior_version},
                     {"bounds", UserBounds(grid, frame, c.tile)},
                     {"updated_at", IsoTime(c.updated_ms)},
                     {"params", Json::parse(c.params_json)}});
  }
  return Json{{"prior_version", storage_->priors().LatestVersion().value_or(0)},
              {"page", page},
              {"page_size", page_size},
              {"total", total},
              {"tiles", tiles}};
}

FilePayload MapService::GetTileChanges(const std::string& tile_text, const std::string& format,
                                       const std::string& kind, double min_confidence,
                                       int64_t min_support,
                                       const std::optional<std::string>& cluster_states) {
  const TileId tile = ParseTile(tile_text);
  const std::optional<std::set<ClusterState>> states = ParseClusterStates(cluster_states);
  if (kind != "" && kind != "new" && kind != "removed")
    throw ApiError(ApiCode::kInvalidArgument, "kind must be new or removed");
  if ((format == "pcd" || format == "ply") && kind.empty()) {
    throw ApiError(ApiCode::kInvalidArgument,
                   "format " + format + " needs kind=new or kind=removed");
  }
  if (format != "json" && format != "pcd" && format != "ply")
    throw ApiError(ApiCode::kInvalidArgument, "format must be json, pcd or ply");
  if (!(min_confidence >= 0 && min_confidence <= 1))
    throw ApiError(ApiCode::kInvalidArgument, "min_confidence must be in [0, 1]");
  if (min_support < 0) throw ApiError(ApiCode::kInvalidArgument, "min_support must be >= 0");
  auto record = storage_->tiles().GetChanges(tile);
  if (!record) throw ApiError(ApiCode::kNotFound, "tile " + tile_text + " has no classification");
  const std::vector<ChangePoint> changes = DecodeChanges(record->changes);
  const MapFrame frame = Frame();
  ClusterVoxelIndex clusters;
  if (states)
    clusters = ClusterVoxelIndex::Load(*storage_, tile, *states, config_.lifecycle.cluster_voxel_m);
  auto keep = [&](const ChangePoint& c) {
    return c.confidence >= min_confidence &&
           static_cast<int64_t>(c.supported_by.size()) >= min_support &&
           (kind.empty() || (kind == "new") == (c.kind == ChangeKind::kNew)) &&
           (!states || clusters.Find(c.kind, c.position));
  };
  if (format != "json") {
    std::vector<ChangeCloudPoint> cloud;
    for (const auto& c : changes) {
      if (!keep(c)) continue;
      cloud.push_back({c.position, c.confidence, static_cast<uint32_t>(c.observed_by.size()),
                       static_cast<uint32_t>(c.supported_by.size())});
    }
    FilePayload p = CloudPayload(cloud, format, frame,
                                 [](const std::string& path, const std::vector<ChangeCloudPoint>& c,
                                    const CloudFrame& f) { WriteChangeCloud(path, c, f); });
    p.prior_version = record->prior_version;
    return p;
  }
  Json fresh = Json::array(), gone = Json::array();
  for (const auto& c : changes) {
    if (!keep(c)) continue;
    const Eigen::Vector3d p = UserPoint(frame, c.position);
    Json j{{"p", {p.x(), p.y(), p.z()}},
           {"confidence", c.confidence},
           {"observed_by", c.observed_by},
           {"supported_by", c.supported_by}};
    if (states) j["cluster_id"] = clusters.Find(c.kind, c.position)->id;
    (c.kind == ChangeKind::kNew ? fresh : gone).push_back(std::move(j));
  }
  Json j{{"tile", tile_text},
         {"prior_version", record->prior_version},
         {"updated_at", IsoTime(record->updated_ms)},
         {"params", Json::parse(record->params_json)},
         {"confidence_formula", "(supported + 1) / (observed + 2)"},
         {"new", fresh},
         {"removed", gone}};
  FilePayload p;
  const std::string text = j.dump();
  p.bytes.assign(text.begin(), text.end());
  p.content_type = "application/json";
  p.prior_version = record->prior_version;
  return p;
}

// ---------------------------------------------------------------- admin jobs

Json MapService::CreateJob(const Json& body) {
  RejectUnknownFields(body,
                      {"type", "tiles", "bbox", "min_confidence", "min_support", "confirmed_only",
                       "params", "version", "cause"},
                      "body");
  const std::string type_text = StringField(body, "type");
  const std::optional<JobType> type =
      ParseEnum<JobType>(type_text);  // commit: POST .../commit only
  Json params = Json::object();
  if (type != JobType::kRollback && (body.contains("version") || body.contains("cause"))) {
    throw ApiError(ApiCode::kInvalidArgument, "'version' and 'cause' are for rollback jobs only");
  }
  if (body.contains("tiles") && body.contains("bbox"))
    throw ApiError(ApiCode::kInvalidArgument, "give tiles or bbox, not both");
  if (body.contains("tiles")) {
    const Json& t = body["tiles"];
    if (!t.is_array() || t.empty() || t.size() > 10000)
      throw ApiError(ApiCode::kInvalidArgument, "field 'tiles': expected 1..10000 tile ids");
    for (const Json& e : t) {
      if (!e.is_string())
        throw ApiError(ApiCode::kInvalidArgument, "field 'tiles': expected strings");
      ParseTile(e.get<std::string>());
    }
    params["tiles"] = t;
  }
  if (body.contains("bbox")) {
    const Json& b = body["bbox"];
    if (!b.is_array() || b.size() != 4)
      throw ApiError(ApiCode::kInvalidArgument,
                     "field 'bbox': expected [min_x, min_y, max_x, max_y]");
    std::string text;
    for (const Json& e : b) {
      if (!e.is_number())
        throw ApiError(ApiCode::kInvalidArgument, "field 'bbox': expected numbers");
      text += (text.empty() ? "" : ",") + ShortestNumber(e.get<double>());
    }
    const std::vector<double> user = ParseBbox(text);
    params["bbox"] = b;
    // The job works on the map's local tile grid; the user's bbox stays as given for readers.
    const Eigen::Vector3d& o = Frame().origin;
    params["local_bbox"] = {user[0] - o.x(), user[1] - o.y(), user[2] - o.x(), user[3] - o.y()};
  }
  if (type == JobType::kRefresh) {
    if (!params.contains("tiles") && !params.contains("bbox"))
      throw ApiError(ApiCode::kInvalidArgument, "refresh needs 'tiles' or 'bbox'");
    if (body.contains("params"))
      throw ApiError(ApiCode::kInvalidArgument, "refresh takes no 'params'");
    params["min_confidence"] =
        body.contains("min_confidence") ? NumberField(body, "min_confidence") : 0.5;
    params["min_support"] = body.contains("min_support") ? IntField(body, "min_support") : 1;
    if (!(params["min_confidence"].get<double>() >= 0 &&
          params["min_confidence"].get<double>() <= 1)) {
      throw ApiError(ApiCode::kInvalidArgument, "field 'min_confidence': must be in [0, 1]");
    }
    if (params["min_support"].get<int64_t>() < 0)
      throw ApiError(ApiCode::kInvalidArgument, "field 'min_support': must be >= 0");
    if (body.contains("confirmed_only")) {
      if (!body["confirmed_only"].is_boolean())
        throw ApiError(ApiCode::kInvalidArgument, "field 'confirmed_only': expected true or false");
      params["confirmed_only"] = body["confirmed_only"];
    }
    RequirePriorVersion();
  } else if (type == JobType::kReclassify) {
    if (body.contains("min_confidence") || body.contains("min_support") ||
        body.contains("confirmed_only")) {
      throw ApiError(ApiCode::kInvalidArgument,
                     "reclassify takes 'params', not min_confidence/min_support/confirmed_only");
    }
    const Json p = body.value("params", Json::object());
    ClassifyConfigFromJson(p, config_.classify);  // validate now, not in the job
    params["params"] = p;
  } else if (type == JobType::kRollback) {
    params = RollbackJobParams(body, RequirePriorVersion());
  } else {
    throw ApiError(ApiCode::kInvalidArgument,
                   "field 'type': must be refresh, reclassify or rollback");
  }
  const int64_t id = storage_->jobs().Create(*type, params.dump(), NowMs());
  wake_.notify_all();
  MD_LOG(kInfo, "job " << id << " (" << type_text << ") queued: " << params.dump());
  return GetJob(id);
}

Json MapService::ListJobs(int64_t page, int64_t page_size) {
  CheckPage(page, page_size);
  Json jobs = Json::array();
  for (const auto& j : storage_->jobs().List(page_size, (page - 1) * page_size))
    jobs.push_back(JobToJson(j));
  return Json{{"page", page}, {"page_size", page_size}, {"jobs", jobs}};
}

Json MapService::GetJob(int64_t job_id) {
  auto j = storage_->jobs().Get(job_id);
  if (!j) throw ApiError(ApiCode::kNotFound, "job " + std::to_string(job_id) + " does not exist");
  return JobToJson(*j);
}

Json MapService::CancelJob(int64_t job_id) {
  const auto before = storage_->jobs().Get(job_id);
  if (!before)
    throw ApiError(ApiCode::kNotFound, "job " + std::to_string(job_id) + " does not exist");
  if (before->state != JobState::kQueued && before->state != JobState::kRunning) {
    throw ApiError(ApiCode::kJobNotCancellable,
                   "job is " + std::string(ToString(before->state)) +
                       "; only queued or running jobs can be cancelled");
  }
  // The state may have moved on since the read; RequestCancel decides atomically.
  storage_->jobs().RequestCancel(job_id, NowMs());
  return GetJob(job_id);
}

}  // namespace mapdelta::server

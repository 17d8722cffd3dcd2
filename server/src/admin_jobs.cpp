// Refresh and reclassify jobs, the shared job context, and classification settings.
#include <chrono>
#include <thread>
#include <unordered_set>

#include "api_json.hpp"
#include "blob_codec.hpp"
#include "change_clusters.hpp"
#include "cluster_voxels.hpp"
#include "commit_passes.hpp"
#include "coverage.hpp"
#include "jobs.hpp"
#include "mapdelta/common/log.hpp"
#include "tile_classifier.hpp"
#include "tile_work.hpp"

namespace mapdelta::server {

void JobContext::Progress(double fraction, const std::string& message) {
  storage.jobs().UpdateProgress(job.id, std::clamp(fraction, 0.0, 1.0), message);
}

void JobContext::CheckShutdown() {
  if (shutting_down()) throw JobInterrupted(false);
}

void JobContext::CheckStop() {
  if (shutting_down()) throw JobInterrupted(false);
  if (storage.jobs().IsCancelRequested(job.id)) throw JobInterrupted(true);
}

void JobContext::WaitForEarlierJobs(std::optional<JobType> of_type) {
  // Polled: earlier jobs are rare with one worker (never) and short-lived with several.
  constexpr auto kPoll = std::chrono::milliseconds(100);
  while (true) {
    const std::optional<EarlierJob> earlier =
        storage.jobs().UnfinishedBefore(job.id, NowMs(), of_type);
    if (!earlier) return;
    if (earlier->claimable) throw JobYield(earlier->id);
    // Meanwhile this worker classifies tiles of the running commits (the earlier one's).
    ClassifyClaimedTiles(storage, config, std::nullopt, shutting_down);
    CheckShutdown();
    std::this_thread::sleep_for(kPoll);
  }
}

Json ToJson(const ClassifyConfig& c) {
  return Json{{"th_ch_m", c.th_ch_m}, {"min_voxel_support", c.min_voxel_support}};
}

ClassifyConfig ClassifyConfigFromJson(const Json& j, const ClassifyConfig& base) {
  RejectUnknownFields(j, {"th_ch_m", "min_voxel_support"}, "params");
  ClassifyConfig c = base;
  if (j.contains("th_ch_m")) c.th_ch_m = NumberField(j, "th_ch_m");
  if (j.contains("min_voxel_support")) {
    const int64_t support = IntField(j, "min_voxel_support");  // checked before narrowing
    if (support < 1 || support > 100000) {
      throw ApiError(ApiCode::kInvalidArgument, "params.min_voxel_support: must be in [1, 100000]");
    }
    c.min_voxel_support = static_cast<int>(support);
  }
  if (!(c.th_ch_m > 0 && c.th_ch_m <= 50)) {
    throw ApiError(ApiCode::kInvalidArgument, "params.th_ch_m: must be in (0, 50]");
  }
  if (c.min_voxel_support < 1 || c.min_voxel_support > 100000) {
    throw ApiError(ApiCode::kInvalidArgument, "params.min_voxel_support: must be >= 1");
  }
  return c;
}

ClassifyConfig CurrentClassifyConfig(Storage& storage, const ClassifyConfig& fallback) {
  if (auto text = storage.tiles().GetSetting("classify"))
    return ClassifyConfigFromJson(Json::parse(*text), fallback);
  return fallback;
}

namespace {

// Tiles a refresh/reclassify job addresses: explicit list, bbox, or (reclassify) all.
std::vector<TileId> JobTiles(Storage& storage, const TileGrid& grid, const Json& params) {
  std::vector<TileId> tiles;
  if (params.contains("tiles")) {
    for (const Json& t : params["tiles"])
      tiles.push_back(*TileId::FromString(t.get<std::string>()));
  } else if (params.contains("bbox")) {
    // local_bbox: the bbox in the map's local frame (jobs queued before frames have none).
    const auto& b = params.contains("local_bbox") ? params["local_bbox"] : params["bbox"];
    for (const TileId& t : grid.TilesInRect(b[0].get<double>(), b[1].get<double>(),
                                            b[2].get<double>(), b[3].get<double>())) {
      tiles.push_back(t);
    }
  } else {
    tiles = storage.tiles().ListAggregated(std::nullopt);
  }
  return tiles;
}

struct PointHash {
  size_t operator()(const Point& p) const {
    const auto h = [](float f) { return std::hash<float>()(f); };
    return h(p.x()) * 73856093u ^ h(p.y()) * 19349663u ^ h(p.z()) * 83492791u;
  }
};
struct PointEq {
  bool operator()(const Point& a, const Point& b) const { return a == b; }
};

// Which change points a refresh merges into the prior.
struct MergeRule {
  double min_confidence = 0.5;
  int64_t min_support = 1;
  bool confirmed_only = false;  // only points of the tile's confirmed clusters (same kind)
  double cluster_voxel_m = 1.0;
};

// Step 1 of a refresh for one tile: its prior at `latest` without the removed points that pass
// the rule, with the new ones that do; nullopt if none passes.
std::optional<RefreshTileWrite> MergeIntoPrior(Storage& storage, const TileId& tile, int64_t latest,
                                               const std::vector<ChangePoint>& changes,
                                               const MergeRule& rule) {
  ClusterVoxelIndex confirmed;
  if (rule.confirmed_only)
    confirmed =
        ClusterVoxelIndex::Load(storage, tile, {ClusterState::kConfirmed}, rule.cluster_voxel_m);
  std::unordered_set<Point, PointHash, PointEq> removed;
  PointCloud added;
  for (const ChangePoint& c : changes) {
    if (c.confidence < rule.min_confidence ||
        static_cast<int64_t>(c.supported_by.size()) < rule.min_support)
      continue;
    if (rule.confirmed_only && !confirmed.Find(c.kind, c.position)) continue;
    if (c.kind == ChangeKind::kRemoved)
      removed.insert(c.position);
    else
      added.push_back(c.position);
  }
  if (removed.empty() && added.empty()) return std::nullopt;
  PointCloud points;
  int64_t from_version = 0;
  if (auto prior = storage.priors().GetTile(tile, latest)) {
    from_version = prior->version;
    for (const Point& p : DecodePoints(prior->points)) {
      if (!removed.count(p)) points.push_back(p);
    }
  }
  RefreshTileWrite w;
  w.tile = tile;
  w.from_version = from_version;
  w.removed = static_cast<int64_t>(removed.size());
  w.added = static_cast<int64_t>(added.size());
  points.insert(points.end(), added.begin(), added.end());
  w.point_count = static_cast<int64_t>(points.size());
  w.points = EncodePoints(points);
  return w;
}

}  // namespace

namespace {

// Step 3 of a refresh: neighbours of refreshed tiles saw the old prior in their margins.
// Idempotent, so a resumed job simply runs it again. No cancel from here: the version exists.
void ReclassifyAround(JobContext& ctx, const TileGrid& grid, const std::vector<TileId>& refreshed,
                      int64_t version, const ClassifyConfig& cc) {
  std::set<TileId> around;
  for (const TileId& t : refreshed) {
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) around.insert(TileId(t.ix() + dx, t.iy() + dy));
    }
  }
  ObservedCache cache(ctx.storage);
  std::vector<TileChangesRecord> records;
  for (const TileId& t : around) {
    ctx.CheckShutdown();
    if (!ctx.storage.tiles().GetState(t)) continue;
    TileClassification c = ClassifyTile(ctx.storage, grid, t, version, cc,
                                        PipelineDetectionParams(ctx.config.pipeline), cache);
    c.record.updated_ms = NowMs();
    records.push_back(std::move(c.record));
  }
  ctx.storage.tiles().ApplyChanges(0, records);
}

}  // namespace

Json RunRefreshJob(JobContext& ctx) {
  ctx.WaitForEarlierJobs();  // it reads and rewrites tiles that earlier jobs write
  const Json params = Json::parse(ctx.job.params_json);
  MergeRule rule;
  rule.min_confidence = params.value("min_confidence", 0.5);
  rule.min_support = params.value("min_support", int64_t{1});
  rule.confirmed_only = params.value("confirmed_only", false);
  rule.cluster_voxel_m = ctx.config.lifecycle.cluster_voxel_m;
  const TileGrid grid(ctx.config.storage.tile_size_m);
  const ClassifyConfig cc = CurrentClassifyConfig(ctx.storage, ctx.config.classify);

  // Resumed after its version was written (crash or shutdown in step 3): finish step 3 only.
  for (const PriorVersionRecord& v : ctx.storage.priors().ListVersions()) {
    if (v.job_id != ctx.job.id || !ctx.job.result_json) continue;
    Json result = Json::parse(*ctx.job.result_json);
    std::vector<TileId> refreshed;
    for (const Json& t : result["tiles"])
      refreshed.push_back(*TileId::FromString(t["tile"].get<std::string>()));
    ReclassifyAround(ctx, grid, refreshed, v.version, cc);
    result["coverage"] = CoverageJson(RecomputeCoverage(ctx.storage));
    result["resumed"] = true;
    return result;
  }

  const std::optional<int64_t> latest = ctx.storage.priors().LatestVersion();
  if (!latest) throw ApiError(ApiCode::kNoPrior, "no prior map to refresh");
  ObservedCache cache(ctx.storage);
  // 1. Compute every tile's new points in memory; nothing is written until step 2.
  std::vector<RefreshTileWrite> writes;
  Json tiles_report = Json::array();
  const std::vector<TileId> tiles = JobTiles(ctx.storage, grid, params);
  for (size_t i = 0; i < tiles.size(); ++i) {
    ctx.CheckStop();
    const TileId& tile = tiles[i];
    auto record = ctx.storage.tiles().GetChanges(tile);
    if (!record) continue;
    std::vector<ChangePoint> changes = DecodeChanges(record->changes);
    if (record->prior_version != *latest) {  // classified against an older prior: redo
      changes = ClassifyTile(ctx.storage, grid, tile, *latest, cc,
                             PipelineDetectionParams(ctx.config.pipeline), cache)
                    .changes;
    }
    std::optional<RefreshTileWrite> w = MergeIntoPrior(ctx.storage, tile, *latest, changes, rule);
    if (!w) continue;
    tiles_report.push_back(
        {{"tile", tile.ToString()}, {"added", w->added}, {"removed", w->removed}});
    writes.push_back(std::move(*w));
    ctx.Progress(0.8 * (i + 1) / tiles.size(), "merged tile " + tile.ToString());
  }
  if (writes.empty()) {
    return Json{{"prior_version", *latest},
                {"tiles", tiles_report},
                {"note", "no change above the thresholds; prior unchanged"}};
  }
  // 2. One transaction: version N+1, its tiles, aggregation reset, log, the job's result.
  PriorVersionRecord meta;
  meta.note = "refresh job " + std::to_string(ctx.job.id);
  Json result{{"prior_version", *latest + 1},
              {"parent_version", *latest},
              {"tiles", tiles_report},
              {"min_confidence", rule.min_confidence},
              {"min_support", rule.min_support}};
  if (rule.confirmed_only) result["confirmed_only"] = true;
  ctx.CheckStop();  // the last point where a cancel stops the refresh
  const int64_t version =
      ctx.storage.tiles().ApplyRefresh(ctx.job.id, meta, writes, result.dump(), NowMs());
  result["prior_version"] = version;

  // 3. Neighbours of refreshed tiles saw the old prior in their margins: reclassify them.
  std::vector<TileId> refreshed;
  for (const auto& w : writes) refreshed.push_back(w.tile);
  ReclassifyAround(ctx, grid, refreshed, version, cc);
  // 4. Sessions' coverage of the refreshed tiles, against their new points.
  result["coverage"] = CoverageJson(RecomputeCoverage(ctx.storage));
  return result;
}

Json RunReclassifyJob(JobContext& ctx) {
  ctx.WaitForEarlierJobs();  // its thresholds apply from here on, after the jobs before it
  const Json params = Json::parse(ctx.job.params_json);
  const ClassifyConfig cc =
      ClassifyConfigFromJson(params.value("params", Json::object()),
                             CurrentClassifyConfig(ctx.storage, ctx.config.classify));
  // The new thresholds become current first, so that later commits use them too.
  ctx.storage.tiles().PutSetting("classify", ToJson(cc).dump());
  const TileGrid grid(ctx.config.storage.tile_size_m);
  const int64_t version = ctx.storage.priors().LatestVersion().value_or(0);
  const std::set<std::string> done = ctx.storage.jobs().TilesDone(ctx.job.id);
  ObservedCache cache(ctx.storage);
  const std::vector<TileId> tiles = JobTiles(ctx.storage, grid, params);
  int64_t new_points = 0, removed_points = 0, count = 0;
  for (size_t i = 0; i < tiles.size(); ++i) {
    ctx.CheckStop();
    if (done.count(tiles[i].ToString()) || !ctx.storage.tiles().GetState(tiles[i])) continue;
    TileClassification c = ClassifyTile(ctx.storage, grid, tiles[i], version, cc,
                                        PipelineDetectionParams(ctx.config.pipeline), cache);
    c.record.updated_ms = NowMs();
    ctx.storage.tiles().ApplyChanges(ctx.job.id, {c.record});
    new_points += c.record.new_count;
    removed_points += c.record.removed_count;
    ++count;
    ctx.Progress(static_cast<double>(i + 1) / tiles.size(), "reclassified " + tiles[i].ToString());
  }
  return Json{{"params", ToJson(cc)},
              {"prior_version", version},
              {"tiles_classified", count},
              {"new_points", new_points},
              {"removed_points", removed_points}};
}

}  // namespace mapdelta::server

// The rollback job: makes an older prior version current again as a new version.
#include <limits>

#include "api_json.hpp"
#include "coverage.hpp"
#include "jobs.hpp"
#include "mapdelta/common/log.hpp"
#include "rollback_clusters.hpp"

namespace mapdelta::server {
namespace {

Json CountsJson(const RollbackClusterCounts& c) {
  return Json{{"unapplied", c.unapplied}, {"reapplied", c.reapplied}};
}

// The version this job already wrote (a crash between the version and the job's finish).
std::optional<PriorVersionRecord> WrittenBy(PriorStore& priors, int64_t job_id) {
  for (const PriorVersionRecord& v : priors.ListVersions()) {
    if (v.job_id == job_id) return v;
  }
  return std::nullopt;
}

}  // namespace

Json RollbackJobParams(const Json& body, int64_t latest) {
  RejectUnknownFields(body, {"type", "version", "cause"}, "body");
  const int64_t version = IntField(body, "version");
  if (version < 1 || version > latest) {
    throw ApiError(ApiCode::kNotFound, "prior version " + std::to_string(version) +
                                           " does not exist (latest: " + std::to_string(latest) +
                                           ")");
  }
  if (version == latest) {
    throw ApiError(ApiCode::kInvalidArgument, "field 'version': " + std::to_string(version) +
                                                  " is already the current version");
  }
  Json params{{"version", version}};
  if (body.contains("cause")) {
    const std::string cause = StringField(body, "cause");
    if (cause.empty() || cause.size() > 500) {
      throw ApiError(ApiCode::kInvalidArgument, "field 'cause': expected 1..500 characters");
    }
    params["cause"] = cause;
  }
  return params;
}

Json RunRollbackJob(JobContext& ctx) {
  const Json params = Json::parse(ctx.job.params_json);
  const int64_t target = params.at("version").get<int64_t>();
  PriorStore& priors = ctx.storage.priors();
  if (const auto written = WrittenBy(priors, ctx.job.id)) {
    // A crash after the version: its cluster changes may be missing (they are idempotent).
    const RollbackClusterCounts counts =
        ReconcileClustersWithRollback(ctx.storage, ctx.job.id, target, written->version, NowMs());
    return Json{{"prior_version", written->version},
                {"copy_of", target},
                {"resumed", true},
                {"coverage", CoverageJson(RecomputeCoverage(ctx.storage))},
                {"clusters", CountsJson(counts)}};
  }
  const std::optional<int64_t> latest = priors.LatestVersion();
  if (!latest || target < 1 || target > *latest) {
    throw ApiError(ApiCode::kNotFound,
                   "prior version " + std::to_string(target) + " does not exist");
  }
  // 1. Every tile with points at the target, as it reads there (the row may be older).
  constexpr double kLow = std::numeric_limits<int32_t>::min();
  constexpr double kHigh = std::numeric_limits<int32_t>::max();
  std::vector<PriorTileRecord> tiles;
  for (const PriorTileRecord& listed : priors.ListTiles(Rect{kLow, kLow, kHigh, kHigh}, target)) {
    ctx.CheckStop();
    auto tile = priors.GetTile(listed.tile, target);
    if (tile) tiles.push_back(std::move(*tile));
  }
  // 2. One transaction: version latest + 1 with exactly those tiles (replace_all: a tile that
  // has points at latest but not at the target reads as empty).
  PriorVersionRecord meta;
  meta.created_ms = NowMs();
  meta.source = PriorSource::kRollback;
  meta.job_id = ctx.job.id;
  meta.note = "rollback job " + std::to_string(ctx.job.id) + ": copy of version " +
              std::to_string(target) +
              (params.contains("cause") ? ", " + params["cause"].get<std::string>() : "");
  ctx.CheckStop();  // the last point where a cancel stops the rollback
  const int64_t version = priors.CreateVersion(meta, tiles, /*replace_all=*/true);
  MD_LOG(kInfo, "prior version " << version << " = copy of version " << target);
  // 3. The clusters follow the map: applied exactly when their refresh is in the target.
  const RollbackClusterCounts counts =
      ReconcileClustersWithRollback(ctx.storage, ctx.job.id, target, version, NowMs());
  // 4. Sessions' coverage against the copied points (every tile has a new row).
  const CoverageRecomputed coverage = RecomputeCoverage(ctx.storage);
  Json out{{"prior_version", version},
           {"copy_of", target},
           {"parent_version", *latest},
           {"tiles", tiles.size()},
           {"clusters", CountsJson(counts)}};
  out["coverage"] = CoverageJson(coverage);
  return out;
}

}  // namespace mapdelta::server

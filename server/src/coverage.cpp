#include "coverage.hpp"

#include <limits>
#include <map>

#include "blob_codec.hpp"
#include "mapdelta/common/error.hpp"
#include "tile_classifier.hpp"

namespace mapdelta::server {
namespace {

// The row of (tile, session) over `prior` (nullopt: the tile has no prior row), with `bits`
// over its points.
CoverageRecord MakeRecord(const TileId& tile, int64_t session_id, const std::string& vehicle_id,
                          int64_t observed_ms, const std::optional<PriorTileRecord>& prior,
                          const PointBits& bits) {
  CoverageRecord r;
  r.tile = tile;
  r.session_id = session_id;
  r.vehicle_id = vehicle_id;
  r.observed_ms = observed_ms;
  r.prior_row_version = prior ? prior->version : 0;
  r.prior_points = static_cast<int64_t>(bits.size());
  r.observed_points = static_cast<int64_t>(bits.Count());
  r.bits = EncodePointBits(bits);
  return r;
}

}  // namespace

PointBits ObservedBits(const ObservedArea& area, const PointCloud& prior_points) {
  PointBits bits(prior_points.size());
  for (size_t i = 0; i < prior_points.size(); ++i) {
    if (area.IsObserved(prior_points[i])) bits.Set(i);
  }
  return bits;
}

std::vector<CoverageRecord> SessionCoverage(Storage& storage, const SessionRecord& session,
                                            const ObservedArea& area,
                                            const std::vector<TileId>& tiles,
                                            int64_t prior_version) {
  std::vector<CoverageRecord> out;
  for (const TileId& tile : tiles) {
    const std::optional<PriorTileRecord> prior = storage.priors().GetTile(tile, prior_version);
    const PointBits bits = prior && prior->point_count > 0
                               ? ObservedBits(area, DecodePoints(prior->points))
                               : PointBits(0);
    out.push_back(
        MakeRecord(tile, session.id, session.vehicle_id, session.created_ms, prior, bits));
  }
  return out;
}

namespace {

// One pass of RecomputeCoverage against `version`, adding to *out.
void RecomputeAt(Storage& storage, int64_t version, CoverageRecomputed* out_total) {
  CoverageRecomputed& out = *out_total;
  constexpr double kLow = std::numeric_limits<int32_t>::min();
  constexpr double kHigh = std::numeric_limits<int32_t>::max();
  const Rect everywhere{kLow, kLow, kHigh, kHigh};
  const std::vector<CoverageRecord> rows = storage.coverage().List(everywhere, 0, false);
  std::map<TileId, std::vector<const CoverageRecord*>> by_tile;
  for (const CoverageRecord& r : rows) by_tile[r.tile].push_back(&r);
  // Which row every tile reads from, without its points (only stale tiles' points are read).
  std::map<TileId, PriorTileRecord> listed;
  for (PriorTileRecord& t : storage.priors().ListTiles(everywhere, version))
    listed.emplace(t.tile, std::move(t));

  ObservedCache octrees(storage);
  std::set<int64_t> sessions_read;
  // Tile by tile: one decode of the tile's points, one transaction for its rows.
  for (const auto& [tile, tile_rows] : by_tile) {
    const auto it = listed.find(tile);
    // Not listed: no row at this version, or an empty one (ListTiles skips those).
    std::optional<PriorTileRecord> prior =
        it != listed.end() ? std::optional(it->second) : storage.priors().GetTile(tile, version);
    const int64_t row_version = prior ? prior->version : 0;
    std::vector<const CoverageRecord*> stale;
    for (const CoverageRecord* row : tile_rows) {
      if (row->prior_row_version != row_version) stale.push_back(row);
    }
    if (stale.empty()) continue;
    PointCloud points;
    if (prior && prior->point_count > 0)
      points = DecodePoints(storage.priors().GetTile(tile, version)->points);
    std::vector<CoverageRecord> writes;
    for (const CoverageRecord* row : stale) {
      PointBits bits(points.size());
      if (!points.empty()) {
        sessions_read.insert(row->session_id);
        if (const ObservedArea* area = octrees.Session(row->session_id))
          bits = ObservedBits(*area, points);
      }
      writes.push_back(
          MakeRecord(tile, row->session_id, row->vehicle_id, row->observed_ms, prior, bits));
    }
    storage.coverage().Put(writes);
    out.rows += static_cast<int64_t>(writes.size());
    out.tiles += 1;
  }
  out.sessions += static_cast<int64_t>(sessions_read.size());
}

}  // namespace

CoverageRecomputed RecomputeCoverage(Storage& storage) {
  CoverageRecomputed out;
  // Against the latest version, again if another version was written meanwhile: a writer that
  // ran concurrently (an import, a rollback beside a refresh) then leaves current rows, whichever
  // pass wrote last.
  std::optional<int64_t> version = storage.priors().LatestVersion();
  while (version) {
    RecomputeAt(storage, *version, &out);
    const std::optional<int64_t> latest = storage.priors().LatestVersion();
    if (latest == version) break;
    version = latest;
  }
  return out;
}

int64_t WriteSessionCoverage(Storage& storage, const SessionRecord& session,
                             const ObservedArea& area, const std::vector<TileId>& tiles) {
  std::optional<int64_t> version = storage.priors().LatestVersion();
  while (true) {
    const std::vector<CoverageRecord> rows =
        SessionCoverage(storage, session, area, tiles, version.value_or(0));
    storage.coverage().Put(rows);
    const std::optional<int64_t> latest = storage.priors().LatestVersion();
    if (latest == version) {
      int64_t covered = 0;
      for (const CoverageRecord& r : rows) covered += r.observed_points > 0 ? 1 : 0;
      return covered;
    }
    version = latest;
  }
}

nlohmann::json CoverageJson(const CoverageRecomputed& r) {
  return {{"rows", r.rows}, {"tiles", r.tiles}, {"sessions", r.sessions}};
}

TileCoverage SummarizeTile(const PriorTileRecord& prior, const std::vector<CoverageRecord>& all,
                           const std::vector<CoverageRecord>& window) {
  TileCoverage c;
  c.tile = prior.tile;
  c.prior_points = prior.point_count;
  auto counts = [&](const CoverageRecord& r) {
    return r.tile == prior.tile && r.observed_points > 0 && r.prior_row_version == prior.version &&
           r.prior_points == prior.point_count;
  };
  for (const CoverageRecord& r : all) {
    if (counts(r) && (!c.last_observed_ms || r.observed_ms > *c.last_observed_ms))
      c.last_observed_ms = r.observed_ms;
  }
  PointBits observed(static_cast<size_t>(prior.point_count));
  for (const CoverageRecord& r : window) {
    if (!counts(r)) continue;
    observed.Or(DecodePointBits(r.bits));
    c.sessions.insert(r.session_id);
    c.vehicles.insert(r.vehicle_id);
  }
  c.observed_points = static_cast<int64_t>(observed.Count());
  return c;
}

}  // namespace mapdelta::server
